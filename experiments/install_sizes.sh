#!/usr/bin/env bash
# Installed size of monovisual3d per extra (docs/install.md): a fresh venv per extra, `pip install`
# of this checkout (not editable), then `du` of the venv's site-packages minus an empty venv's.
# Usage: bash experiments/install_sizes.sh core viz docs vision ros sim dev   (slow: minutes per extra)
set -u
SRC="$(cd "$(dirname "$0")/.." && pwd)"
OUT="${OUT:-/tmp/mv3d-install-sizes}"
mkdir -p "$OUT"
python3 -m venv "$OUT/empty"
base=$(du -sk "$OUT"/empty/lib/python3.*/site-packages | cut -f1)
echo "empty venv site-packages: ${base} KiB" > "$OUT/result.txt"
for extra in "$@"; do
  d="$OUT/venv-$extra"
  rm -rf "$d"
  python3 -m venv "$d"
  spec="$SRC"; [ "$extra" = core ] || spec="$SRC[$extra]"
  if "$d/bin/pip" install -q "$spec" > "$OUT/log-$extra.txt" 2>&1; then
    kb=$(du -sk "$d"/lib/python3.*/site-packages | cut -f1)
    n=$("$d/bin/pip" list --format=freeze 2>/dev/null | wc -l)
    echo "$extra: $(( (kb - base) / 1024 )) MiB in $n packages" >> "$OUT/result.txt"
  else
    echo "$extra: install failed (see $OUT/log-$extra.txt)" >> "$OUT/result.txt"
  fi
  rm -rf "$d"
done
cat "$OUT/result.txt"
