"""``python -m spectratac.protocol.accel_check``: the set-up check that cobs and crcmod run
on their C extensions (spectratac.protocol.accel); exit code 1 with what to do when not.

It is its own module because `spectratac.protocol` imports `accel` on the way: running
``-m spectratac.protocol.accel`` executed that module a second time, as __main__, and runpy
warned about it (RuntimeWarning) on every set-up.
"""

from __future__ import annotations

import sys

from spectratac.protocol.accel import AccelerationError, require_extensions


def main() -> int:
    try:
        require_extensions()
    except AccelerationError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print("cobs and crcmod C extensions in use")
    return 0


if __name__ == "__main__":
    sys.exit(main())
