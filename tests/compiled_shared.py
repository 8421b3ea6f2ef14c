"""Helper of the compiled-loads tests (tests/test_compiled_loads.py, tests/test_compiled_reflector.py):
the C enums' layout against the Python side's, records equal to a tolerance, bitwise resume and
state restore, and the refusal without a compiler."""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from magsail_mj.compiled import SOURCE_DIR, CompiledLoadsError
from magsail_mj.config import ConfigError, load_config
from magsail_mj.export import read_timeseries
from magsail_mj.run import run_scenario


def c_enum_offsets(src: str, prefix: str, *, constants: Mapping[str, int] | None = None) -> dict[str, int]:
    """The values of the C enum whose names start with ``prefix_`` in the source text ``src`` (the
    enum whose first member is ``prefix_… = 0``): each member one more than the one before, or
    ``= <number>``, ``= prefix_X`` or ``= prefix_X + <product of numbers and constants>``."""
    first = re.search(rf"^\s+{prefix}_\w+\s*=\s*0\b", src, re.M)
    assert first is not None, f"no enum of {prefix}_ members starting at 0"
    term = r"[\w* ]+"
    member = re.compile(rf"\s+{prefix}_(\w+)(?:\s*=\s*(?:(\d+)|{prefix}_(\w+)(?:\s*\+\s*({term}))?))?\s*,?")
    names = dict(constants or {})
    out: dict[str, int] = {}
    k = 0
    for line in src[first.start() :].splitlines():
        m = member.match(line)
        if not m:
            if line.strip().startswith("};"):
                break
            continue
        name, value, base, plus = m.groups()
        if value is not None:
            k = int(value)
        elif base is not None:
            k = out[base]
            if plus is not None:
                k += math.prod(int(t) if t.isdigit() else names[t] for t in plus.replace(" ", "").split("*"))
        out[name] = k
        k += 1
    return out


def random_states(
    rng: np.random.Generator,
    data: Any,
    *,
    n: int,
    rate_max_rad_s: float,
    steps: int,
    dt: float,
    speed_max_m_s: float | None = None,
) -> Iterator[int]:
    """Sets ``data`` of a free-flying body (free joint first: ``qpos[3:7]`` its quaternion,
    ``qvel[0:3]`` its velocity, ``qvel[3:6]`` its body rates) to ``n`` random states in turn and
    yields the state's number after each: the attitude uniform, the rates uniform in
    ±``rate_max_rad_s`` per axis, the velocity uniform in ±``speed_max_m_s`` (unless ``None``:
    left as it is), the time a whole number of steps ``dt`` below ``steps``."""
    for i in range(n):
        q = rng.normal(size=4)
        data.qpos[3:7] = q / np.linalg.norm(q)
        data.qvel[3:6] = rng.uniform(-rate_max_rad_s, rate_max_rad_s, 3)
        if speed_max_m_s is not None:
            data.qvel[0:3] = rng.uniform(-speed_max_m_s, speed_max_m_s, 3)
        data.time = float(rng.integers(0, steps)) * dt
        yield i


def assert_c_layout(
    source: str, blocks: Sequence[tuple[str, Sequence[tuple[str, int]], str | None]], *, constants=None
) -> None:
    """Each ``(prefix, fields, end)`` of ``blocks``: the ``prefix_`` enum of the C source
    ``source`` (a file of :data:`~magsail_mj.compiled.SOURCE_DIR`) has the fields' order and lengths,
    and its member ``end`` (unless ``None``) is the block's length."""
    src = (SOURCE_DIR / source).read_text()
    for prefix, fields, end in blocks:
        c = c_enum_offsets(src, prefix, constants=constants)
        k = 0
        for name, n in fields:
            assert c[name] == k, (prefix, name, c[name], k)
            k += n
        if end is not None:
            assert c[end] == k, (prefix, c[end], k)


def assert_records_close(a: Mapping[str, Any], b: Mapping[str, Any], *, rel_tol: float, dtypes: bool = False) -> None:
    """The records ``b`` have the keys of ``a`` and each series within ``rel_tol`` of the series'
    largest absolute value in ``a``, of the same shape (and dtype with ``dtypes``)."""
    assert sorted(a) == sorted(b)
    for key in a:
        x, y = np.asarray(a[key], dtype=float), np.asarray(b[key], dtype=float)
        assert x.shape == y.shape, key
        if dtypes:
            assert np.asarray(a[key]).dtype == np.asarray(b[key]).dtype, key
        scale = max(float(np.abs(x).max()), 1e-300)
        assert float(np.abs(x - y).max()) <= rel_tol * scale, (key, float(np.abs(x - y).max()), scale)


def assert_resume_is_bitwise(config: Path, overrides: list[str], tmp_path: Path, *, stop_after_s: float) -> dict:
    """The run of ``config`` with ``overrides`` stopped after ``stop_after_s`` and resumed equals the
    run that went through, every series bit for bit; returns the series."""
    cfg = load_config(config, overrides)
    run_scenario(cfg, tmp_path / "full")
    run_scenario(cfg, tmp_path / "cut", stop_after_s=stop_after_s)
    run_scenario(cfg, tmp_path / "cut", resume=True)
    a, b = read_timeseries(tmp_path / "full"), read_timeseries(tmp_path / "cut")
    assert sorted(a) == sorted(b)
    assert all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)
    return a


def assert_set_state_continues_bitwise(make: Callable[[], Any], *, steps_before: int, steps_after: int = 50) -> None:
    """A simulation from ``make()`` stepped ``steps_before`` steps, its state taken, then stepped
    ``steps_after`` more, ends where a fresh one given that state and stepped as far ends: ``qpos``,
    ``qvel`` and the plugin state bit for bit."""
    sim = make()
    sim.step(steps_before)
    state = sim.get_state()
    sim.step(steps_after)
    after = (sim.data.qpos.copy(), sim.data.qvel.copy(), sim.data.plugin_state.copy())
    other = make()
    other.set_state(state)
    other.step(steps_after)
    assert np.array_equal(other.data.qpos, after[0]) and np.array_equal(other.data.qvel, after[1])
    assert np.array_equal(other.data.plugin_state, after[2])


def assert_missing_compiler_is_refused(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, load: Callable[..., Any], *, config: Path
) -> None:
    """With ``MAGSAIL_CC`` naming no program (and an empty library cache), ``load(config, …)`` of
    compiled loads raises a :class:`CompiledLoadsError` (a config error) that names ``sim.loads``,
    the compiler and the Python path; the Python path runs without a compiler."""
    monkeypatch.setenv("MAGSAIL_CC", str(tmp_path / "no-such-cc"))
    monkeypatch.setenv("MAGSAIL_COMPILED_CACHE", str(tmp_path / "cache"))
    with pytest.raises(CompiledLoadsError, match=r"sim\.loads: 'compiled' needs a C compiler.*no-such-cc") as err:
        load(config, "sim.duration_s=10", "sim.loads='compiled'")
    assert isinstance(err.value, ConfigError)
    assert "sim.loads = 'python'" in str(err.value)
    assert load(config, "sim.duration_s=10").run().status == "completed"  # the Python path needs none
