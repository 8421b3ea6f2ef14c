"""Regenerate the MJCF of every scenario config in models/ (written next to it, same stem).

    python scripts/build_models.py            # write all
    python scripts/build_models.py --check    # exit 1 if any committed MJCF differs
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from magsail_mj.config import load_config
from magsail_mj.io import atomic_path
from magsail_mj.scenarios import build_scenario
from magsail_mj.sweep import is_sweep_file

MODELS = Path(__file__).resolve().parents[1] / "models"


def generated_xml(config: Path) -> str:
    """The MJCF text that `magsail build` writes for ``config``."""
    return build_scenario(load_config(config)).spec.to_xml()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only compare, write nothing")
    args = ap.parse_args(argv)
    stale = []
    for config in sorted(MODELS.rglob("*.toml")):
        if is_sweep_file(config):
            continue
        xml = generated_xml(config)
        target = config.with_suffix(".xml")
        if target.exists() and target.read_text() == xml:
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
