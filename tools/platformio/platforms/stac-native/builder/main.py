"""SCons build script of the stac-native platform: build the program from the env's sources
plus the folder named by `custom_extra_src` (the C unit tests), with the system gcc.
`pio run -e <env> -t exec` builds and runs it; a failing test run fails the command."""

import os
import subprocess
import sys

from SCons.Script import AlwaysBuild, Default, DefaultEnvironment

env = DefaultEnvironment()
env.Replace(AR="ar", AS="as", CC="gcc", CXX="g++", LINK="gcc", RANLIB="ranlib",
            OBJCOPY="objcopy", SIZETOOL="size", PROGSUFFIX="")

extra_dir = env.GetProjectOption("custom_extra_src", "")
exclude = env.GetProjectOption("custom_extra_exclude", "").split()
if extra_dir:
    src = os.path.join(env.subst("$PROJECT_DIR"), extra_dir)
    env.Append(CPPPATH=[src])
    filt = ["+<*.c>"] + [f"-<{name}>" for name in exclude]
    env.Append(PIOBUILDFILES=env.CollectBuildFiles("$BUILD_DIR/extra", src, filt))


def run_program(target, source, env):
    """Run the built program and show its report (bounded, so a hang fails the run)."""
    del target, env
    try:
        result = subprocess.run([source[0].get_abspath()], capture_output=True, text=True,
                                timeout=600, check=False)
    except subprocess.TimeoutExpired:
        sys.stdout.write("program did not finish within 600 s\n")
        return 1
    sys.stdout.write(result.stdout + result.stderr)
    sys.stdout.flush()
    return result.returncode


program = env.BuildProgram()
AlwaysBuild(env.Alias("exec", program, run_program))
Default([program])
