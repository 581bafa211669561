"""Thread counts of the parallel kernels: by work, capped by the limit and by numba's pool."""

from __future__ import annotations

import os
import subprocess
import sys

import numba
import pytest

from monovisual3d.errors import InputError
from monovisual3d.kernels.threads import (
    MIN_WORK_PER_THREAD,
    check_threads,
    kernel_threads,
    max_threads,
    thread_limit,
    threads_for,
)


def test_small_work_gets_one_thread():
    assert threads_for(0) == 1
    assert threads_for(MIN_WORK_PER_THREAD - 1) == 1


def test_large_work_gets_the_pool_and_never_more():
    assert threads_for(10**15) == max_threads() == numba.config.NUMBA_NUM_THREADS
    assert threads_for(2 * MIN_WORK_PER_THREAD) == min(2, max_threads())


def test_requested_and_limit_cap_the_count():
    assert threads_for(10**15, requested=1) == 1
    assert threads_for(10**15, requested=10**6) == max_threads()  # numba cannot start more than its pool
    with thread_limit(1):
        assert threads_for(10**15) == 1
        with thread_limit(None):  # the inner block lifts the cap
            assert threads_for(10**15) == max_threads()
        assert threads_for(10**15, requested=max_threads()) == max_threads()  # an explicit request wins
    assert threads_for(10**15) == max_threads()


@pytest.mark.parametrize("bad", [0, -2, 1.5, True, "2"])
def test_bad_thread_counts_are_rejected(bad):
    with pytest.raises(InputError, match="threads: got"):
        check_threads(bad)
    with pytest.raises(InputError, match="threads: got"):
        threads_for(10, requested=bad)
    with pytest.raises(InputError, match="threads: got"):
        with thread_limit(bad):
            pass


def test_kernel_threads_sets_and_restores_numba_count():
    before = numba.get_num_threads()
    with kernel_threads(0) as n:
        assert n == 1 == numba.get_num_threads()
    assert numba.get_num_threads() == before
    with pytest.raises(RuntimeError):
        with kernel_threads(0):
            raise RuntimeError("boom")
    assert numba.get_num_threads() == before


def test_numba_num_threads_env_caps_the_pool():
    code = (
        "from monovisual3d.kernels.threads import threads_for, kernel_threads\n"
        "import os\n"
        "with kernel_threads(10**15) as n: pass\n"
        "print(threads_for(10**15), n, os.environ.get('OMP_WAIT_POLICY'))\n"
    )
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    env.pop("OMP_WAIT_POLICY", None)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.split() == ["1", "1", "PASSIVE"]
    env["OMP_WAIT_POLICY"] = "ACTIVE"  # the user's choice is kept
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.split() == ["1", "1", "ACTIVE"]
