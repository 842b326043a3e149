"""The regression benchmarks `python -m tools.bench` runs: one entry per benchmark.

Each entry is a module of this folder run as `python -m tools.bench.<module> ARGS --json` from
the repository root, in a process of its own (its threads, servers and busy loops end with it).
Every figure it prints is a ratio to a reference measured in the same run (benchlib); the entry
names its headline figure, the one a run and the measurements log show first. `quick` are the
arguments of the few-seconds version (`--quick`: does every benchmark still run?), `full` those
of the measurement; `needs` names the programs it cannot run without (skipped when missing).
"""

from __future__ import annotations

import re
import shutil
from dataclasses import dataclass


@dataclass(frozen=True)
class Benchmark:
    name: str
    module: str  # tools.bench.<module>
    description: str  # one line
    figure: str  # what the headline figure is
    headline: str  # regular expression matching the headline figure's name
    full: tuple[str, ...] = ()
    quick: tuple[str, ...] = ()
    needs: tuple[str, ...] = ()  # executables on PATH

    def args(self, quick: bool) -> tuple[str, ...]:
        return self.quick if quick else self.full

    def command(self, quick: bool) -> list[str]:
        """The command line (after the interpreter) of one run, with --json."""
        return ["-m", f"tools.bench.{self.module}", *self.args(quick), "--json"]

    def missing(self) -> list[str]:
        return [tool for tool in self.needs if shutil.which(tool) is None]

    def is_headline(self, figure_name: str) -> bool:
        return re.search(self.headline, figure_name) is not None


BENCHMARKS: tuple[Benchmark, ...] = (
    Benchmark(
        "protocol", "protocol",
        "frame decoders' throughput and false accepts of damaged frames",
        "incremental decoder, sample frames/s against a minimal split-COBS-CRC loop",
        r"^incremental decoder$",
        quick=("--frames", "3000", "--corrupt", "20000"),
    ),
    Benchmark(
        "streaming", "streaming",
        "frame-to-user latency over a pty, samples/s at speed=max, CPU for N devices",
        "frame-to-user latency p99 against the raw pty's p99",
        r"^frame-to-user latency p99$",
        quick=("--frames", "50", "--samples", "200", "--devices", "2", "--seconds", "1",
               "--rounds", "1"),
    ),
    Benchmark(
        "ft", "ft",
        "F/T drivers' parsing and pty throughput, simulated F/T sensors' CPU",
        "Bota driver parse, records/s against an unchecked NumPy decode",
        r"^bota driver parse$",
        quick=("--records", "2000", "--seconds", "0.3", "--rounds", "1"),
    ),
    Benchmark(
        "recording", "recording",
        "recorder write rate, format 4 against the compact channels, dataset build",
        "recorder write, samples/s against a raw read of the file",
        r"^recorder write$",
        quick=("--samples", "2000", "--ft-rate", "100", "--rounds", "1",
               "--live-samples", "100"),
    ),
    Benchmark(
        "rosbag", "rosbag",
        "ROS 2 bag export rate beside dataset build of the same recording",
        "export rosbag (sqlite3), messages/s against dataset build's rows/s",
        r"^export rosbag, sqlite3$",
        quick=("--samples", "400", "--ft-rate", "100", "--rounds", "1"),
    ),
    Benchmark(
        "sim-device", "sim_device",
        "bytes/s the simulated device takes in one feed call against 4 KiB calls",
        "feed in one call against 4 KiB calls (1.0: linear)",
        r"^sim feed, one call$",
        quick=("--megabytes", "0.25", "--rounds", "1"),
    ),
    Benchmark(
        "twin", "twin",
        "50-min calibration session, population and one integration window of the twin",
        "calibration session generation against allocating its outputs",
        r"^calibration session generation$",
        full=("--busy", "2"),
        quick=("--rounds", "1"),
    ),
    Benchmark(
        "firmware", "firmware",
        "SAMPLE frame encode and superloop pass on the native build; STM32 image size",
        "SAMPLE frame encode against a memcpy of its bytes",
        r"^SAMPLE frame encode \(\d+ B\)$",
        quick=("--no-image",),
        needs=("cc",),
    ),
    Benchmark(
        "ondevice", "ondevice",
        "the firmware's decoder on the Cortex-M4F (QEMU, cycle model) and its sizes",
        "paper model (f32) decode time at 96 MHz against the 10 ms sample period",
        r"^decode paper \(resmlp 128x3, f32\): time at 96 MHz$",
        full=("--firmware",),
        quick=("--samples", "5"),
        needs=("qemu-system-arm", "arm-none-eabi-gcc"),
    ),
    Benchmark(
        "decoder-runtime", "decoder_runtime",
        "paper decoder's single-sample latency (NumPy) and the paper recipe's training time",
        "live sample p99 (assembly + network) against the network alone",
        r"^paper decoder live sample p99 \(assembly \+ network\)$",
        quick=("--calls", "200", "--samples", "1000", "--epochs", "1"),
    ),
    Benchmark(
        "decoder-speed", "decoder",
        "speed against error: integration time x LED sequence x model size",
        "the linear model's latency against the paper's setting (50 ms, white, ResMLP)",
        r"^50ms-white/linear latency$",
        full=("--out", "build/bench/decoder"),
        quick=("--quick", "--out", "build/bench/decoder-quick"),
    ),
    Benchmark(
        "decoder-variants", "decoder",
        "the paper's recipe against each improvement beyond it, same data and splits",
        "worst force-axis MAE reduction of the best variant against the 25 % target",
        r"^target: worst force-axis MAE reduction of the best variant$",
        full=("--variants", "--out", "build/bench/decoder"),
        quick=("--variants", "--quick", "--only", "contact", "--out",
               "build/bench/decoder-quick"),
    ),
    Benchmark(
        "training", "training",
        "training throughput beside busy loops; the paper recipe on 266,000 rows",
        "MLP training beside two busy loops against quiet",
        r"^MLP training, \d+ busy loops$",
        full=("--nets", "mlp,paper,best", "--busy", "2", "--paper-rows", "266000"),
        quick=("--epochs", "1", "--rounds", "1", "--busy", "1"),
    ),
    Benchmark(
        "demo", "demo",
        "`spectratac demo` end to end, quiet and beside two busy loops",
        "the demo's wall time against the 120 s budget",
        r"^make demo, quiet$",
        full=("--busy", "2"),
        quick=("--duration", "20", "--epochs", "1"),
    ),
    Benchmark(
        "live", "live",
        "live page latency: a sample's frame at the host to its estimate in the browser",
        "p99 against a bare probe in the estimate's own message",
        r"^frame arrival -> browser p99$",
        full=("--busy", "2"),
        quick=("--seconds", "2", "--warmup", "1"),
        needs=("chromium", "chromedriver"),
    ),
    Benchmark(
        "live-guard", "live_guard",
        "the live server against hostile clients: refusals, memory, stalls, joins",
        "hostile requests refused against requests tried (1.0: all)",
        r"^hostile requests refused$",
        quick=("--joins", "20"),
    ),
    Benchmark(
        "reliability", "reliability",
        "16 simulated devices under random faults and one recording: nothing lost unaccounted",
        "samples lost unaccounted against samples sent (0)",
        r"^reliability$",
        full=("--devices", "16", "--seconds", "300"),
        quick=("--devices", "4", "--seconds", "10"),
    ),
    Benchmark(
        "midpress", "midpress",
        "live Fz error joined mid-press against joined at rest (the rest search)",
        "mid-press contact MAE against the at-rest join's",
        r"^Fz MAE in contact, mid-press$",
        quick=("--seconds", "5"),
    ),
    Benchmark(
        "heldout-forward", "heldout_forward",
        "the figure `train` prints to expect against the error then met on later sessions",
        "share of printed figures within 1.3x of the next sessions' error",
        r"^share within 1\.3x: printed figure$",
        quick=("--units", "0", "--session-s", "10", "--train", "3", "--next", "1"),
    ),
    Benchmark(
        "guided", "guided",
        "Snake on units 1-6 with the demo model adapted from a guided minute, no F/T",
        "presses with exactly one right command, of those played (base model beside)",
        r"^Snake presses right, adapted$",
        quick=("--units", "1", "--epochs", "5"),
    ),
    Benchmark(
        "forward-figure", "forward_figure",
        "on a skin ageing over weeks: every recipe's printed figure against the next sessions' "
        "error, train's time estimate against its wall time",
        "share of forward figures and estimates within 1.5x",
        r"^share within 1\.5x: forward figure and estimate$",
        full=("--busy", "2"),
        quick=("--sessions", "12", "--train", "9", "--session-s", "3", "--epochs", "1",
               "--budget", "5", "--recipes", "paper,auto", "--no-recal"),
    ),
    Benchmark(
        "generalisation", "generalisation",
        "decoders on a unit and sessions they never saw; few-shot recalibration",
        "auto recipe's held-out-unit MAE against the paper recipe's",
        r"^target \(a\) held-out unit: auto / paper$",
        quick=("--quick", "--units", "2", "--sessions-per-unit", "2", "--session-s", "30",
               "--full-cal-s", "60", "--test-s", "30", "--minutes", "0.5", "--epochs", "1",
               "--best-epochs", "1", "--budget", "5", "--no-progress"),
    ),
)

#: Modules of this folder that are not benchmarks (live_limits: live_guard's newer probes).
HELPERS = ("__init__", "__main__", "benchlib", "live_limits", "registry", "results")


def by_name() -> dict[str, Benchmark]:
    return {b.name: b for b in BENCHMARKS}
