"""Seeds spread over Dask (``--workers``/``--scheduler`` of ``bench accuracy``, ``bench active`` and ``reproduce``):
the same numbers as in this process, only faster."""

from __future__ import annotations

from pathlib import Path

import pytest

from monovisual3d.active.bench import run_active_bench
from monovisual3d.batch.spread import check_spread, spread_map
from monovisual3d.bench.accuracy import run_accuracy
from monovisual3d.errors import InputError
from monovisual3d.experiments.reproduce import ReproduceConfig, reproduce


@pytest.fixture(scope="module")
def scheduler() -> str:
    """A local cluster of 2 worker processes for the whole module (started once: a few seconds)."""
    from monovisual3d.batch.run import dask_client

    with dask_client(2, dashboard_address=None) as client:
        yield client.scheduler.address


def test_spread_map_keeps_the_order_and_reports_each_item(scheduler: str) -> None:
    items = [(2, k) for k in range(6)]
    seen: list[int] = []
    assert spread_map(pow, items, progress=lambda i, r: seen.append(i)) == [1, 2, 4, 8, 16, 32]
    assert seen == list(range(6))
    seen.clear()
    assert spread_map(pow, items, scheduler=scheduler, progress=lambda i, r: seen.append(i)) == [1, 2, 4, 8, 16, 32]
    assert sorted(seen) == list(range(6))


@pytest.mark.parametrize(
    ("workers", "scheduler", "match"),
    [
        (-1, None, "workers: got -1, expected 0"),
        (2, "tcp://x:1", "workers, scheduler: give at most one"),
        (True, None, "workers"),
    ],
)
def test_bad_spread_arguments_are_one_line_errors(workers, scheduler, match: str) -> None:
    with pytest.raises(InputError, match=match):
        check_spread(workers, scheduler)
    with pytest.raises(InputError, match=match):
        run_accuracy(quick=True, methods=("bayes",), only=("paper-clean",), workers=workers, scheduler=scheduler)


def _without_runtimes(results: dict) -> dict:
    return {
        c: {m: {k: v for k, v in s.items() if k != "runtime_s"} for m, s in block["methods"].items()}
        for c, block in results["results"].items()
    }


def test_bench_accuracy_spread_gives_the_same_errors(scheduler: str) -> None:
    kwargs = {"quick": True, "methods": ("bayes", "paper"), "only": ("paper-clean", "greenhouse")}
    here = run_accuracy(**kwargs)
    spread = run_accuracy(**kwargs, scheduler=scheduler)
    assert _without_runtimes(spread) == _without_runtimes(here)
    assert here["spread"] is None and spread["spread"] == {"workers": None, "scheduler": scheduler}


def test_bench_active_spread_gives_the_same_runs(scheduler: str) -> None:
    kwargs = {
        "conditions": ("greenhouse",),
        "seeds": (0, 1),
        "max_views": 2,
        "n_candidates": 8,
        "strategies": ("nbv", "random"),
        "timing_repeats": 1,
    }
    here = run_active_bench(**kwargs)
    spread = run_active_bench(**kwargs, scheduler=scheduler)
    for key in ("table", "chosen", "stopping"):
        assert spread["results"]["greenhouse"][key] == here["results"]["greenhouse"][key]


def test_reproduce_spread_gives_the_same_records(scheduler: str, tmp_path: Path) -> None:
    cfg = ReproduceConfig.quick_config(figures=False, ghost_counts=(1, 2), ghost_scenes=1)
    calls: list[tuple[int, int, str]] = []
    here = reproduce(tmp_path / "here", cfg)
    spread = reproduce(tmp_path / "spread", cfg, scheduler=scheduler, progress=lambda d, t, w: calls.append((d, t, w)))

    def key(r: object) -> dict:
        return {k: v for k, v in r.to_dict().items() if k != "seconds"}  # type: ignore[attr-defined]

    assert [key(r) for r in spread.records] == [key(r) for r in here.records]
    assert calls[-1][0] == calls[-1][1]  # the progress reaches its total
    assert (tmp_path / "spread" / "report.md").is_file()


def test_an_unreachable_scheduler_is_a_one_line_error() -> None:
    import dask

    from monovisual3d.batch.run import dask_client

    with (
        dask.config.set({"distributed.comm.timeouts.connect": "1s"}),
        pytest.raises(InputError, match=r"^scheduler: cannot connect to 'tcp://127.0.0.1:1': "),
    ):
        with dask_client(scheduler="tcp://127.0.0.1:1"):
            pass


@pytest.mark.parametrize("command", [["bench", "accuracy", "--quick"], ["bench", "active"], ["reproduce", "--quick"]])
def test_spread_flags_conflict_exits_2_naming_the_flags(command: list[str]) -> None:
    from typer.testing import CliRunner

    from monovisual3d.cli import app

    result = CliRunner().invoke(app, [*command, "--workers", "1", "--scheduler", "tcp://127.0.0.1:1"])
    assert result.exit_code == 2 and "--workers, --scheduler: give at most one of them" in result.output
