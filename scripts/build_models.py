"""Regenerate the MJCF of every scenario config in models/ (written next to it, same stem).

python scripts/build_models.py            # write all
python scripts/build_models.py --check    # exit 1 if any committed MJCF differs
"""

from __future__ import annotations

import argparse
import math
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

from magsail_mj.config import load_config
from magsail_mj.io import atomic_path
from magsail_mj.scenario import build_scenario
from magsail_mj.structure.fileformat import is_structure_file
from magsail_mj.sweep import is_sweep_file

MODELS = Path(__file__).resolve().parents[1] / "magsail_mj" / "concepts"


def generated_xml(config: Path) -> str:
    """The MJCF text that `magsail build` writes for ``config``."""
    return build_scenario(load_config(config)).spec.to_xml()


# Numbers in the MJCF come out of floating-point sums whose last bits depend on the machine's
# SIMD paths (e.g. 0.9041597208106965 here, ...6572 elsewhere: 4e-14 relative). A relative
# tolerance of 1e-9 is five orders above that noise and far below any real parameter change.
MJCF_RTOL = 1e-9


def _same_value(a: str, b: str, rtol: float) -> bool:
    if a == b:
        return True
    xs, ys = a.split(), b.split()
    if len(xs) != len(ys):
        return False
    for x, y in zip(xs, ys):
        if x == y:
            continue
        try:
            fx, fy = float(x), float(y)
        except ValueError:
            return False
        if not math.isclose(fx, fy, rel_tol=rtol, abs_tol=rtol * 1e-3):
            return False
    return True


def _round_off_zero(value: str, *, atol: float = 1e-12) -> bool:
    """Whether an attribute written on one side only is a number (or vector) within ``atol`` of 0:
    MuJoCo omits an attribute at its zero default, so a round-off value such as a spring reference
    of 3.6e-15 m appears or not depending on the last bits of the NumPy build."""
    try:
        return all(abs(float(x)) <= atol for x in value.split())
    except ValueError:
        return False


def mjcf_difference(committed: str, generated: str, *, rtol: float = MJCF_RTOL) -> str | None:
    """First difference between two MJCF texts, or None when they agree.

    Element tags, order, attribute names and text must match exactly; numeric attribute values
    (also space-separated vectors) must agree to ``rtol`` relative; an attribute written on one side
    only must be a number within round-off of zero (its default).
    """
    a_root, b_root = ET.fromstring(committed), ET.fromstring(generated)
    a_all, b_all = list(a_root.iter()), list(b_root.iter())
    if len(a_all) != len(b_all):
        return f"{len(a_all)} elements committed, {len(b_all)} generated"
    for a, b in zip(a_all, b_all):
        where = f"<{a.tag} name={a.get('name')!r}>"
        if a.tag != b.tag:
            return f"{where}: tag {a.tag!r} vs {b.tag!r}"
        one_side = a.attrib.keys() ^ b.attrib.keys()
        if any(not _round_off_zero(a.get(key, b.get(key))) for key in one_side):
            return f"{where}: attributes {sorted(a.attrib)} vs {sorted(b.attrib)}"
        for key in a.attrib.keys() & b.attrib.keys():
            if not _same_value(a.attrib[key], b.attrib[key], rtol):
                return f"{where}: {key}={a.attrib[key]!r} vs {b.attrib[key]!r}"
        if (a.text or "").strip() != (b.text or "").strip():
            return f"{where}: text differs"
    return None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only compare, write nothing")
    args = ap.parse_args(argv)
    stale = []
    for config in sorted(MODELS.rglob("*.toml")):
        if is_sweep_file(config) or is_structure_file(config):
            continue
        xml = generated_xml(config)
        target = config.with_suffix(".xml")
        if target.exists() and mjcf_difference(target.read_text(), xml) is None:
            continue
        stale.append(target)
        if not args.check:
            with atomic_path(target) as tmp:
                tmp.write_text(xml)
    for path in stale:
        print(("stale: " if args.check else "wrote: ") + str(path.relative_to(MODELS.parent)))
    return 1 if (args.check and stale) else 0


if __name__ == "__main__":
    sys.exit(main())
