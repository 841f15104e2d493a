"""scripts/constraints-oldest.txt pins exactly the lower bounds pyproject.toml states.

``scripts/deps_check.sh oldest`` installs the project under that file; if a bound in
pyproject.toml moves and the file does not, the "oldest" run would test versions the
project no longer claims (or refuse to install).  Results: docs/dependencies.md.
"""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]
#: Pinned beside a requirement that brings them (dask[distributed] -> distributed).
TRANSITIVE = {"distributed": "dask"}


def _lower_bounds() -> dict[str, str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    reqs = list(project["dependencies"]) + list(project["optional-dependencies"]["test"])
    out = {}
    for text in reqs:
        req = Requirement(text)
        lows = [s.version for s in req.specifier if s.operator == ">="]
        assert len(lows) == 1, f"pyproject.toml: {text!r} needs exactly one lower bound (>=)"
        out[req.name.lower()] = lows[0]
    return out


def _pins() -> dict[str, str]:
    pins = {}
    for line in (ROOT / "scripts" / "constraints-oldest.txt").read_text().splitlines():
        line = line.split("#")[0].strip()
        if line:
            m = re.fullmatch(r"([A-Za-z0-9_.\-]+)==([0-9][0-9A-Za-z.]*)", line)
            assert m, f"constraints-oldest.txt: {line!r} is not NAME==VERSION"
            pins[m[1].lower()] = m[2]
    return pins


def _release(v: str) -> tuple[int, ...]:
    parts = [int(p) for p in v.split(".")]
    return tuple(parts + [0] * (3 - len(parts)))


def test_every_lower_bound_is_pinned_at_itself():
    bounds, pins = _lower_bounds(), _pins()
    missing = sorted(set(bounds) - set(pins))
    assert not missing, f"constraints-oldest.txt lacks {missing}"
    for name, low in bounds.items():
        assert _release(pins[name]) >= _release(low), f"{name}: pinned {pins[name]} below the bound {low}"
        # the pin is the bound itself, or the first release after it where the bound's own
        # release cannot be installed (documented in docs/dependencies.md)
        assert _release(pins[name])[:2] == _release(low)[:2], f"{name}: pin {pins[name]} is not the oldest {low}"


def test_no_pin_without_a_requirement():
    bounds, pins = _lower_bounds(), _pins()
    extra = sorted(n for n in set(pins) - set(bounds) if TRANSITIVE.get(n) not in bounds)
    assert not extra, f"constraints-oldest.txt pins {extra}, which pyproject.toml does not ask for"
