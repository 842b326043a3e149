"""On-device decoding benchmark: what the firmware's decoder (firmware/core/stac_model.c) costs
on the STM32F411 at 96 MHz for the paper's model and TrainSpec.best(), in each weight format.

Time. QEMU (netduinoplus2, Cortex-M4F) runs the check image (PlatformIO env `model_check`,
the firmware's -Os flags) with -icount, so virtual time advances a fixed step per guest
instruction and SysTick stamps count instructions: every stac_model_push is stamped, and in
the same run a reference of known cost is stamped too, a float32 dot product of 1024
multiply-adds (the network's inner loop). A two-instruction calibration loop converts ticks
to instructions. QEMU models no cycle timing (and no DWT), so cycles come from a cycle model:

  cycles = MACs x (cycles per MAC of the format's inner loop)
         + (other instructions) x OTHER_CPI
         + weight bytes / 16 x FLASH_WAIT_STATES

The inner loops' cycles are the Cortex-M4 TRM timings (ARM DDI 0439, 3.3 and 7.2) of the
instructions gcc emits for stac_model.c's `linear` (checked against the ELF's disassembly
at every run: the bench stops if the loops changed). Branch refill P is taken as 2 (the TRM
gives 1-3). OTHER_CPI covers assembly, features, GELU (tanhf), LayerNorm and heads: integer
ops 1, loads 2, branches 2-4, VDIV/VSQRT 14 cycles; 1.5 is a documented assumption, and
cycles are also given at CPI 1 and 2 (`cycles_range`). Flash: at 96 MHz the F411 needs 3
wait states; the ART accelerator's instruction cache holds the loops, but weights stream
through its data cache, one 128-bit line (16 B) per miss. The reference dot product's cycles
come from the same TRM table. Each time is a ratio to the reference measured in the same run.

Size. Image bytes per format against the model store (MAX_IMAGE_BYTES); static RAM of the
interpreter's state (stac_model_t + stac_model_state_t, from the ELF's symbols) and the
interpreter's code (stac_model.o plus the libm functions it pulls in); with --firmware, the
STM32 image (env blackpill_uart) against its 64 KiB of flash (sectors 0-3), and that image
plus an uploaded paper-size float32 model in the model store (sectors 4-7, 448 KiB) against
the 512 KiB flash, and static RAM against the 128 KiB.

    python -m tools.bench.ondevice [--json] [--samples 40] [--firmware]
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from tests.firmware.model_check import model_check_host as check
from tools.bench import benchlib
from tools.platformio import pio

REPO = Path(__file__).resolve().parents[2]

PAPER_F32 = "paper (resmlp 128x3, f32)"
CLOCK_HZ = 96e6
BUDGET_MS = 10.0  # one sample period at the fastest integration (100 Hz)
FLASH = 512 * 1024
RAM = 128 * 1024
PROGRAM_FLASH = 64 * 1024  # flash sectors 0-3; sectors 4-7 are the model store
FLASH_WAIT_STATES = 3  # STM32F411 at 96 MHz, 2.7-3.6 V (RM0383 table 5)
OTHER_CPI = 1.5
P = 2  # branch pipeline refill (TRM: 1-3)
# Cortex-M4 TRM cycle counts (ARM DDI 0439B 3.3, 7.2) of what the inner loops hold; a taken
# branch costs 1 + P. A mnemonic missing here stops the bench: extend the table.
TRM = {
    "add": 1, "add.w": 1, "adds": 1, "adds.w": 1, "sub": 1, "sub.w": 1, "subs": 1,
    "subs.w": 1, "cmp": 1, "cmp.w": 1, "mov": 1, "mov.w": 1, "movs": 1, "lsls": 1,
    "ldr": 2, "ldr.w": 2, "ldrh": 2, "ldrh.w": 2, "ldrsb": 2, "ldrsb.w": 2,
    "sxtb": 1, "sxtb.w": 1, "sbfx": 1, "asr": 1, "asr.w": 1, "vldr": 2, "vmov": 1,
    "vcvtb.f32.f16": 1, "vcvt.f32.s32": 1, "vmla.f32": 3,
    # the model store's CRC-32C loop (tests/firmware/test_store_watchdog.py)
    "eor": 1, "eors": 1, "eor.w": 1, "and": 1, "ands": 1, "and.w": 1, "ldrb": 2, "ldrb.w": 2,
}  # fmt: skip
BRANCHES = ("b", "b.n", "b.w", "bne.n", "bcs.n", "bhi.n", "bcc.n", "bls.n", "bne.w", "bcs.w")
# What stac_model.c pulls in from newlib's libm.
LIBM = re.compile(r"(__ieee754_)?(tanhf|expf|sqrtf|sqrt|expm1f|fabsf|finitef)|with_errnof"
                  r"|xflowf\.constprop\.0|__math_(o|u)flowf")  # fmt: skip
ELF = REPO / "build" / "pio" / "model_check" / "firmware.elf"


def disassembly(elf: Path, function: str) -> list[tuple[int, str, str]]:
    """(address, mnemonic, operands) of each instruction of `function`."""
    out = subprocess.run(
        ["arm-none-eabi-objdump", "-d", "--no-show-raw-insn", str(elf)],
        capture_output=True, text=True, check=True, timeout=120,
    ).stdout  # fmt: skip
    m = re.search(rf"^[0-9a-f]+ <{re.escape(function)}>:\n(.*?)\n\n", out, re.S | re.M)
    if m is None:
        raise SystemExit(f"{function} not found in {elf}")
    rows = []
    for line in m.group(1).splitlines():
        parts = line.strip().split("\t")
        if len(parts) >= 2 and parts[0].endswith(":"):
            rows.append((int(parts[0][:-1], 16), parts[1], parts[2] if len(parts) > 2 else ""))
    return rows


def _target(operands: str) -> int | None:
    m = re.match(r"([0-9a-f]+) <", operands)
    return int(m.group(1), 16) if m else None


def _cycles(mnemonic: str, operands: str) -> int:
    """TRM cycles of one instruction (a taken branch: 1 + P; VLDM of N registers: 1 + N)."""
    if mnemonic in BRANCHES:
        return 1 + P
    if mnemonic == "vldmia":
        m = re.search(r"\{s(\d+)(?:-s(\d+))?\}", operands)
        if m is None:
            raise SystemExit(f"unexpected VLDM operands {operands!r}: extend the cycle model")
        return 1 + (int(m.group(2) or m.group(1)) - int(m.group(1)) + 1)
    if mnemonic == "vmov" and operands.count(",") == 3:
        return 2  # two core registers to two single-precision registers
    if mnemonic not in TRM:
        raise SystemExit(f"no TRM timing for {mnemonic!r} in an inner loop: extend TRM")
    return TRM[mnemonic]


def inner_loops(rows: list[tuple[int, str, str]], macs_per_iteration: int) -> list[dict]:
    """The loops whose iteration holds `macs_per_iteration` VMLAs, with their TRM cycles and
    instructions per multiply-add. A backward conditional branch closes a plain loop; a
    backward `b` to X closes a rotated one: X up to the first conditional branch (taken, into
    the body), then the body up to that `b`."""
    at = {addr: i for i, (addr, _, _) in enumerate(rows)}
    loops = []
    for j, (addr, mnem, ops) in enumerate(rows):
        head_addr = _target(ops)
        if mnem not in BRANCHES or head_addr is None or head_addr >= addr or head_addr not in at:
            continue
        h = at[head_addr]
        if mnem in ("b", "b.n", "b.w"):
            k = next((i for i in range(h, j) if rows[i][1] in BRANCHES), None)
            if k is None or _target(rows[k][2]) not in at:
                continue
            b = at[_target(rows[k][2])]
            if not h < b <= j or any(r[1] in BRANCHES for r in rows[b:j]):
                continue
            body = rows[h : k + 1] + rows[b : j + 1]
        else:
            body = rows[h : j + 1]
            if any(r[1] in BRANCHES for r in body[:-1]):
                continue
        if [r[1] for r in body].count("vmla.f32") != macs_per_iteration:
            continue
        cycles = sum(_cycles(m, o) for _, m, o in body)
        loops.append({"mnemonics": [r[1] for r in body],
                      "cycles_per_mac": cycles / macs_per_iteration,
                      "insns_per_mac": len(body) / macs_per_iteration})  # fmt: skip
    return loops


def loop_costs(elf: Path) -> tuple[dict[str, dict], float]:
    """Cycles and instructions per multiply-add of linear()'s three inner loops (by weight
    format), and TRM cycles per multiply-add of the reference dot product."""
    per_mac: dict[str, dict] = {}
    for loop in inner_loops(disassembly(elf, "linear"), 4):
        m = loop["mnemonics"]
        fmt = "f16" if "vcvtb.f32.f16" in m else "i8" if "vcvt.f32.s32" in m else "f32"
        if fmt in per_mac:
            raise SystemExit(f"two {fmt} inner loops in linear(): update the bench")
        per_mac[fmt] = loop
    ref = inner_loops(disassembly(elf, "ref_dot.constprop.0"), 1)
    if sorted(per_mac) != ["f16", "f32", "i8"] or len(ref) != 1:
        raise SystemExit(f"inner loops not recognised ({sorted(per_mac)}): update the bench")
    ref_cycles = ref[0]["cycles_per_mac"]
    return per_mac, float(ref_cycles)


def symbol_sizes(elf: Path) -> dict[str, int]:
    out = subprocess.run(["arm-none-eabi-nm", "-S", str(elf)], capture_output=True, text=True,
                         check=True, timeout=60).stdout  # fmt: skip
    sizes = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 4:
            sizes[parts[3]] = int(parts[1], 16)
    return sizes


def build(env: str) -> Path:
    result = pio.run(["run", "-e", env], timeout=900)
    if result.returncode != 0:
        raise SystemExit(result.stdout[-3000:] + result.stderr[-3000:])
    return REPO / "build" / "pio" / env / "firmware.elf"


def models(epochs: int) -> dict:
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.train import TrainSpec, train
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    scene = scenes.calibration_session(seed=3, duration_s=30.0)
    ds = from_twin_session(generate_session(scene, seed=3), scene)
    specs = {"paper": TrainSpec.paper(epochs=epochs), "best": TrainSpec.best(epochs=epochs)}
    return {name: train(ds, spec, progress=False) for name, spec in specs.items()}, ds


def macs(dec) -> tuple[int, int]:
    """(multiply-adds of the network's linear layers, weights) per sample."""
    from spectratac.decode.networks import layer_shapes

    rt = dec.runtime
    shapes = layer_shapes(rt.arch, rt.features.n_features, rt.heads.n_out)
    n = sum(o * i for _, o, i in shapes)
    return n, n


def timing_figures(args, elf: Path) -> list[benchlib.Figure]:
    from spectratac.decode.export import model_image as mi

    per_mac, ref_per_mac = loop_costs(elf)
    decs, ds = models(args.epochs)
    session = check.session_of(ds).head(args.samples)
    figures: list[benchlib.Figure] = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, dec in decs.items():
            n_mac, n_weights = macs(dec)
            for weights in mi.WEIGHT_FORMATS:
                image = mi.encode(dec, weights, limit=None)
                work = Path(tmp) / f"{name}-{weights}"
                result = check.run_qemu(elf, image, session, work)
                if result.returncode != 0:
                    raise SystemExit(f"QEMU model check failed: {result.stderr[-2000:]}")
                got, trailer = check.output_of(work)
                err = check.errors(dec, got, check.reference(mi.as_stored(dec, weights), session))
                ticks_per_insn = trailer["flags"] / (2.0 * check.MC_CALIB_ITERS)
                ref_insns = trailer["ticks"] / ticks_per_insn
                insns = float(np.median(got["ticks"][got["ret"] == 1])) / ticks_per_insn
                loop = per_mac[weights]
                other = max(insns - n_mac * loop["insns_per_mac"], 0.0)
                wbytes = n_weights * {"f32": 4, "f16": 2, "i8": 1}[weights]
                flash = wbytes / 16 * FLASH_WAIT_STATES

                def cycles(cpi: float, n_mac=n_mac, weights=weights, other=other, flash=flash):
                    return n_mac * per_mac[weights]["cycles_per_mac"] + other * cpi + flash

                cyc = cycles(OTHER_CPI)
                ref_cycles = check.MC_REF_LEN * ref_per_mac
                ms = cyc / CLOCK_HZ * 1e3
                store = mi.MAX_IMAGE_BYTES
                label = f"{name} ({dec.runtime.arch[0]} {dec.runtime.arch[1]}x{dec.runtime.arch[2]}, {weights})"  # noqa: E501
                extra = {
                    "recipe": name, "weights": weights, "macs": n_mac,
                    "inputs": dec.runtime.n_inputs, "features": dec.runtime.features.n_features,
                    "instructions": round(insns), "loop_cycles_per_mac": loop["cycles_per_mac"],
                    "loop_instructions_per_mac": loop["insns_per_mac"],
                    "other_instructions": round(other), "flash_wait_cycles": round(flash),
                    "cycles_range": [round(cycles(1.0)), round(cycles(2.0))],
                    "max_abs_error_vs_python": max(err["max_abs"].values()),
                    "flags_disagree": err["flags_disagree"], "samples": err["n"],
                }  # fmt: skip
                figures += [
                    benchlib.Figure(f"decode {label}: QEMU instructions", insns, "insn/sample",
                                    "1024-MAC dot product", ref_insns, insns / ref_insns, extra),
                    benchlib.Figure(f"decode {label}: cycle model", cyc, "cycles/sample",
                                    "1024-MAC dot product (TRM)", ref_cycles, cyc / ref_cycles,
                                    extra),
                    benchlib.Figure(f"decode {label}: time at 96 MHz", ms, "ms/sample",
                                    "10 ms sample budget", BUDGET_MS, ms / BUDGET_MS, extra),
                    benchlib.Figure(f"model image {label}", len(image), "B",
                                    "model store (MAX_IMAGE_BYTES)", store, len(image) / store,
                                    {"fits": len(image) <= store}),
                ]  # fmt: skip
    return figures


def size_figures(elf: Path) -> list[benchlib.Figure]:
    sizes = symbol_sizes(elf)
    state = sizes["g_model"] + sizes["g_state"]
    obj = REPO / "build" / "pio" / "model_check" / "src" / "core" / "stac_model.o"
    out = subprocess.run(["arm-none-eabi-size", "-B", "-d", str(obj)], capture_output=True,
                         text=True, check=True, timeout=60).stdout  # fmt: skip
    code = int(out.splitlines()[1].split()[0])
    libm = sum(v for k, v in sizes.items() if LIBM.fullmatch(k))
    return [
        benchlib.Figure("interpreter static RAM (stac_model_t + state)", state, "B",
                        "STM32F411 RAM", RAM, state / RAM,
                        {"stac_model_t": sizes["g_model"], "stac_model_state_t": sizes["g_state"]}),
        benchlib.Figure("interpreter code (stac_model.o + libm)", code + libm, "B",
                        "STM32F411 flash", FLASH, (code + libm) / FLASH,
                        {"stac_model.o": code, "libm": libm}),
    ]  # fmt: skip


def firmware_figures(paper_f32_bytes: int) -> list[benchlib.Figure]:
    from spectratac.decode.export import model_image as mi

    elf = build("blackpill_uart")
    out = subprocess.run(["arm-none-eabi-size", "-A", "-d", str(elf)], capture_output=True,
                         text=True, check=True, timeout=60).stdout  # fmt: skip
    s = {m[1]: int(m[2]) for m in re.finditer(r"^(\.\S+)\s+(\d+)\s+\d+", out, flags=re.M)}
    flash = s[".isr_vector"] + s[".text"] + s.get(".ARM.exidx", 0) + s.get(".data", 0)
    ram = s.get(".data", 0) + s[".bss"]
    total = flash + paper_f32_bytes
    fits = flash <= PROGRAM_FLASH and paper_f32_bytes <= mi.MAX_IMAGE_BYTES
    return [
        benchlib.Figure("firmware flash (sectors 0-3)", flash, "B", "64 KiB program flash",
                        PROGRAM_FLASH, flash / PROGRAM_FLASH,
                        {"headroom": PROGRAM_FLASH - flash}),
        benchlib.Figure("firmware + uploaded paper float32 model: flash", total, "B",
                        "512 KiB flash", FLASH, total / FLASH,
                        {"firmware": flash, "model": paper_f32_bytes,
                         "model_store": mi.MAX_IMAGE_BYTES, "fits": fits}),
        benchlib.Figure("firmware static RAM (image as built)", ram, "B", "128 KiB RAM", RAM,
                        ram / RAM, {"data": s.get(".data", 0), "bss": s[".bss"]}),
    ]  # fmt: skip


def main() -> None:
    p = benchlib.parser(__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=40, help="samples decoded per model")
    p.add_argument("--epochs", type=int, default=1, help="training epochs (cost is the same)")
    p.add_argument(
        "--firmware", action="store_true", help="also build env blackpill_uart for the flash budget"
    )
    args = p.parse_args()
    if shutil.which("qemu-system-arm") is None or shutil.which("arm-none-eabi-gcc") is None:
        raise SystemExit("needs qemu-system-arm and gcc-arm-none-eabi (apt)")
    elf = build("model_check")
    figures = timing_figures(args, elf) + size_figures(elf)
    if args.firmware:
        paper = next(
            f for f in figures if f.name.startswith("model image paper") and "f32" in f.name
        )
        figures += firmware_figures(int(paper.value))
    benchlib.report(figures, args.json)


if __name__ == "__main__":
    main()
