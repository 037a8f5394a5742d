"""``python -m exits`` (with test/ on the path; ``make exits`` does it): see exits.cycles."""

from __future__ import annotations

import os
import sys

from support.standalone import isolate

_, _SDK_DOMAIN = isolate()
os.environ["PYTHONFAULTHANDLER"] = "1"  # a node that crashes prints every thread's Python stack

from exits.cycles import main  # noqa: E402

sys.exit(main(sdk_domain=_SDK_DOMAIN))
