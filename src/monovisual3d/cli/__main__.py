"""``python -m monovisual3d.cli``."""

from . import main

main()
