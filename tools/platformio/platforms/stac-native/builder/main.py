"""SCons build script of the stac-native platform: build the target of tools/firmware/build.toml
that the env names in `custom_native_target` (sources, include folders, defines and flags all
come from that description, shared with the package build) with the system gcc.
`pio run -e <env>` builds it; `-t exec` also runs a program target (a failing run fails the
command)."""

import importlib.util
import os
import subprocess
import sys

from SCons.Script import AlwaysBuild, Default, DefaultEnvironment

env = DefaultEnvironment()
# No SIZETOOL: PlatformIO's program-size check is for the flash images of embedded targets.
env.Replace(AR="ar", AS="as", CC="gcc", CXX="g++", LINK="gcc", RANLIB="ranlib",
            OBJCOPY="objcopy", PROGSUFFIX="")

PROJECT = env.subst("$PROJECT_DIR")


def description_target(name):
    """Target `name` of tools/firmware/build.toml, read by the project's own reader."""
    script = os.path.join(PROJECT, "tools", "firmware", "build.py")
    spec = importlib.util.spec_from_file_location("stac_native_build", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.target(name)


name = env.GetProjectOption("custom_native_target", "")
if not name:
    sys.stderr.write("stac-native: set custom_native_target to a target of "
                     "tools/firmware/build.toml\n")
    env.Exit(1)
target = description_target(name)
shared = target.kind == "shared"
env.Append(
    CCFLAGS=list(target.flags),
    LINKFLAGS=list(target.flags) + list(target.link_flags),
    CPPPATH=[str(d) for d in target.include_dirs],
    CPPDEFINES=[(k, f'\\"{v}\\"') for k, v in target.defines],
)
compile_one = env.SharedObject if shared else env.Object
objects = [
    compile_one(os.path.join("$BUILD_DIR", "obj", os.path.relpath(str(src), PROJECT)[:-2]),
                str(src))
    for src in target.sources
]
output = os.path.join("$BUILD_DIR", target.output)
built = env.SharedLibrary(output, objects) if shared else env.Program(output, objects)


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


if not shared:
    AlwaysBuild(env.Alias("exec", built, run_program))
Default([built])
