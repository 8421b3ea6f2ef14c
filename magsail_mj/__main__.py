"""``python -m magsail_mj``: the ``magsail`` command (same verbs, options and exit statuses)."""

from __future__ import annotations

import sys

from magsail_mj.entry import main

if __name__ == "__main__":
    sys.exit(main())
