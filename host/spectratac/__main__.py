import sys

from spectratac.cli import main

sys.exit(main())
