"""SCons build script of the stac-stm32 platform: compile with arm-none-eabi-gcc from PATH,
link with the board's linker script, make a .bin for DFU, print the size against the budget.
`pio run -t upload` flashes over the STM32 ROM USB DFU bootloader with dfu-util."""

import subprocess

from SCons.Script import AlwaysBuild, Default, DefaultEnvironment

env = DefaultEnvironment()
board = env.BoardConfig()
cpu = board.get("build.cpu")
machine = [f"-mcpu={cpu}", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16"]


def build_id():
    """git describe of the checkout (16 characters at most, as INFO.build_id holds)."""
    try:
        out = subprocess.run(
            ["git", "describe", "--always", "--dirty", "--abbrev=7"],
            cwd=env.subst("$PROJECT_DIR"), capture_output=True, text=True, timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        out = ""
    return (out or "unknown")[-15:]


env.Replace(
    AR="arm-none-eabi-gcc-ar",
    AS="arm-none-eabi-as",
    CC="arm-none-eabi-gcc",
    CXX="arm-none-eabi-g++",
    LINK="arm-none-eabi-gcc",
    OBJCOPY="arm-none-eabi-objcopy",
    RANLIB="arm-none-eabi-gcc-ranlib",
    SIZETOOL="arm-none-eabi-size",
    PROGNAME="firmware",
    PROGSUFFIX=".elf",
    UPLOADER="dfu-util",
    UPLOADCMD="$UPLOADER -a 0 -s 0x08000000:leave -D $SOURCE",
)
env.Append(
    CCFLAGS=[*machine, "-ffunction-sections", "-fdata-sections"],
    CPPDEFINES=[("STAC_BUILD_ID", f'\\"{build_id()}\\"')],
    # the board's build.ldscript is added by PlatformIO itself
    LINKFLAGS=[
        *machine,
        "-nostartfiles",
        "--specs=nano.specs",
        "-Wl,--gc-sections",
        "-Wl,-Map,${BUILD_DIR}/firmware.map",
    ],
    LIBS=["m"],  # newlib's libm: the on-device decoder (stac_model.c) uses expf, tanhf, sqrt
)

elf = env.BuildProgram()
bin_file = env.Command(
    "$BUILD_DIR/${PROGNAME}.bin", elf, "$OBJCOPY -O binary $SOURCE $TARGET"
)
size = env.Alias("size", elf, "$SIZETOOL -A -d $SOURCE")
AlwaysBuild(size)
upload = env.Alias("upload", bin_file, "$UPLOADCMD")
AlwaysBuild(upload)
env.AddPostAction(elf, "$SIZETOOL -B -d $TARGET")
Default([bin_file])
