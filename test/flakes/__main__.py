"""``python -m flakes`` (with test/ on the path; ``make flakes`` does it): see flakes.census."""

from __future__ import annotations

import sys

from flakes.census import main

sys.exit(main())
