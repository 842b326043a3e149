"""PlatformIO's tool-scons entry point, supplied offline from the pip `scons` package that the
project's virtual environment already holds (PlatformIO runs this with that interpreter)."""

import sys

import SCons.Script

if __name__ == "__main__":
    sys.exit(SCons.Script.main())
