"""`SimDevice`: the firmware core (native build) with the twin answering on its buses.

The core runs unmodified: its I2C transfers reach register-level VEML3328 models, its LED PWM
settings drive the twin's LED timeline, and its UART frames go to `on_tx`. Time is whatever
the caller says it is (`step(now_us)`), so the device can run in real time or as fast as the
host can go (`run()`).

Register models: by default the native library's (firmware/ports/native/veml_model.c, a C
mirror of the twin's `Veml3328`) answer the register reads, and the twin is asked only for
the counts of each completed window (`TwinRig.read_window`); windows the twin evaluated ahead
(its lookahead plan) are handed to the library, which answers them without calling back.
`registers="python"` routes every transfer to the twin's own `Veml3328` instead; both give
the same frames for the same seed (tests/device/test_sim_models.py).

`settings=` (a hard-case scene's acquisition settings, `sim.scene_config`) configures the
firmware with them at boot, so the scene plays saturated or dark as it is meant to.

`model_store=PATH` keeps the firmware's model store (the flash an uploaded decoder is written
to) in that file, so the model is there again when a new SimDevice boots with the same file;
without it the store lives in the instance only.

>>> from spectratac.sim.named_scenes import make_scene
>>> frames = []
>>> dev = SimDevice(make_scene("idle"), seed=1, on_tx=lambda data, t: frames.append(data))
>>> from spectratac.protocol.generated.messages import GetInfo
>>> dev.feed(b"\\x00" + __import__("spectratac.protocol").protocol.encode_frame(GetInfo(), seq=1))
>>> dev.step(1000)
>>> __import__("spectratac.protocol").protocol.decode_frame(frames[0][:-1]).message.board
'native-sim'
"""

from __future__ import annotations

import ctypes
import logging
import os
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np

from spectratac.sim import native
from spectratac.sim.generated.native_abi import RX_CAPACITY, STORE_CAPACITY
from spectratac.sim.model_store import ModelStoreError
from spectratac.twin.electronics import SD_ALS, SensorConfig
from spectratac.twin.errors import I2CNack
from spectratac.twin.rig import TwinRig, WindowPlan
from spectratac.twin.scene_model import Scene
from spectratac.twin.unit import UnitParams

log = logging.getLogger("spectratac.sim")
TxSink = Callable[[bytes, int], bool | None]  # (frame bytes, device µs) -> False to refuse


class SimDevice:
    def __init__(
        self,
        scene: Scene,
        seed: int = 0,
        *,
        unit: UnitParams | None = None,
        absent: Iterable[int] = (),
        on_tx: TxSink | None = None,
        board: str = "native-sim",
        uid: bytes | None = None,
        baud: int = 0,
        registers: Literal["native", "python"] = "native",
        lookahead: bool = True,
        model_store: str | Path | None = None,
        settings: Mapping[str, Any] | None = None,
    ) -> None:
        if registers not in ("native", "python"):
            raise ValueError(f"registers={registers!r}: choose 'native' or 'python'")
        self.lib = native.load()
        self.rig = TwinRig(scene, unit, seed, lookahead=lookahead)
        self.absent = frozenset(absent)
        self.registers = registers
        self.on_tx = on_tx
        self.now_us = 0  # 64-bit device time of the current step
        self.i2c_errors = 0  # exceptions inside the twin, reported as bus errors
        self._duties = np.zeros((3, 3))
        self._duties_dirty_at: int | None = None
        self._confs: dict[int, tuple[SensorConfig, bool]] = {}
        self._pushed: WindowPlan | None = None  # the plan the library holds
        self._plan_rows: tuple[WindowPlan, np.ndarray] | None = None
        self._next = (ctypes.c_uint32 * 3)()
        self._evaluated = ctypes.c_uint32()
        self._mem = (ctypes.c_uint64 * ((self.lib.stac_sim_sizeof() + 7) // 8))()
        self._ptr = ctypes.cast(self._mem, ctypes.c_void_p)
        # keep the callback objects alive as long as the instance
        python_regs = registers == "python"
        self._cb = native.Callbacks(
            None,
            native.I2C_FN(self._i2c) if python_regs else native.I2C_FN(),
            native.PWM_FN(self._pwm),
            native.TX_FN(self._tx),
            native.CLOCK_FN(),
        )
        self._window_cb = native.WINDOW_FN(self._window)
        uid = (
            uid
            if uid is not None
            else bytes(np.random.default_rng(seed).integers(0, 256, 12, dtype=np.uint8))
        )
        caps = self.lib.stac_sim_default_capabilities()
        name = board.encode("ascii")
        if python_regs:
            err = self.lib.stac_sim_init(
                self._ptr, ctypes.byref(self._cb), name, caps, uid, baud, 0
            )
        else:
            present = sum(1 << k for k in range(3) if k not in self.absent)
            err = self.lib.stac_sim_init_models(
                self._ptr,
                ctypes.byref(self._cb),
                self._window_cb,
                present,
                name,
                caps,
                uid,
                baud,
                0,
            )
        if err != 0:
            raise native.NativeBuildError(f"stac_sim_init failed ({err})")
        if model_store is not None:
            self._attach_store(Path(model_store))
        self._flush_duties()  # the firmware switched the LEDs off while booting
        if settings:
            self._boot_configure(settings)

    def _boot_configure(self, settings: Mapping[str, Any]) -> None:
        """Configure the firmware with a scene's acquisition settings right after boot, as
        if its operator had; the ACK goes nowhere (no host has spoken yet), so the host's
        first GET_CONFIG reads them and its samples carry their config_id."""
        from spectratac.protocol import encode_frame
        from spectratac.sim.scene_config import configure_message

        sink, self.on_tx = self.on_tx, None
        try:
            self.feed(b"\x00" + encode_frame(configure_message(settings), seq=0))
            self.step(self.now_us)
        finally:
            self.on_tx = sink

    def _attach_store(self, path: Path) -> None:
        """Keep the model store in `path` (created erased when missing) and boot it."""
        if self.lib.stac_sim_model_store(self._ptr, os.fsencode(path)) != 0:
            raise ModelStoreError(
                f"cannot use {path} as a model store: it must be a file of exactly "
                f"{STORE_CAPACITY} bytes (or not exist yet) in a writable folder. Delete it "
                f"to start with an empty store, or name another file with model_store=PATH."
            )

    def flash_fault(self, countdown: int) -> None:
        """Fault injection: the `countdown`-th flash operation from now (1: the next erase or
        program) and all after it fail; 0 ends the fault. A failing program stops half-way."""
        self.lib.stac_sim_flash_fault(self._ptr, countdown)

    @property
    def in_bootloader(self) -> bool:
        """True once ENTER_BOOTLOADER was carried out: the simulated MCU then runs ST's ROM
        bootloader, which neither reads nor answers SpectraTac frames."""
        return bool(self.lib.stac_sim_in_bootloader(self._ptr))

    # --- time and bytes --------------------------------------------------------------------
    def step(self, now_us: int) -> None:
        """Run one superloop pass at device time `now_us` (64-bit µs, never decreasing)."""
        self.now_us = max(now_us, self.now_us)
        self.lib.stac_sim_step64(self._ptr, self.now_us)
        self._flush_duties()

    def run(self, max_steps: int) -> int:
        """While streaming (and no fed bytes wait), step at each next wake-up time, at most
        `max_steps` times: `step(next_wake_us())` in a loop, run inside the library."""
        steps = int(self.lib.stac_sim_run(self._ptr, max_steps))
        self.now_us = int(self.lib.stac_sim_now64(self._ptr))
        self._flush_duties()
        return steps

    def feed(self, data: bytes) -> None:
        """Bytes from the host; steps the core at the current time if its buffer fills.

        Offers at most one receive buffer's worth per call, so the bytes copied stay linear in
        `data` however large it is (offering the whole rest each time copied it per chunk)."""
        view = memoryview(data)
        while view:
            offer = view[:RX_CAPACITY]
            taken = self.lib.stac_sim_rx_feed(self._ptr, bytes(offer), len(offer))
            view = view[taken:]
            if view:
                self.step(self.now_us)

    def next_wake_us(self) -> int:
        """64-bit device time by which the core wants its next step."""
        wake32 = self.lib.stac_sim_next_wake_us(self._ptr)
        return self.now_us + ((wake32 - self.now_us) & 0xFFFF_FFFF) % 0x8000_0000

    def sensor_transfer(self, bus: int, now_us: int, write: bytes, read_len: int) -> bytes:
        """One transfer straight to the register model of sensor `bus` (tests, debugging), as
        the firmware's I2C would make it; raises I2CNack if the model does not acknowledge."""
        self._flush_duties()
        if self.registers == "python":
            return self.rig.sensors[bus].transfer(now_us, write, read_len)
        out = ctypes.create_string_buffer(max(read_len, 1))
        rc = self.lib.stac_sim_sensor_transfer(
            self._ptr, bus, now_us, write, len(write), out, read_len
        )
        if rc == native.I2C_NACK:
            raise I2CNack(f"sensor model {bus} did not acknowledge {write.hex()}")
        if rc != native.I2C_OK:
            raise native.NativeBuildError(f"sensor model {bus}: transfer failed ({rc})")
        return out.raw[:read_len]

    @property
    def streaming(self) -> bool:
        return bool(self.lib.stac_sim_streaming(self._ptr))

    # --- callbacks from C (must never raise) -------------------------------------------------
    def _t64(self, now32: int) -> int:
        return self.now_us + ((now32 - self.now_us) & 0xFFFF_FFFF) % 0x8000_0000

    def _i2c(self, _user, now32, bus, addr, wr, wr_len, rd, rd_len, _timeout):  # type: ignore[no-untyped-def]
        try:
            if bus in self.absent or addr != 0x10 or bus > 2:
                return native.I2C_NACK
            self._flush_duties()
            reply = self.rig.sensors[bus].transfer(
                self._t64(now32), ctypes.string_at(wr, wr_len), rd_len
            )
            if rd_len:
                ctypes.memmove(rd, reply, rd_len)
            return native.I2C_OK
        except I2CNack:
            return native.I2C_NACK
        except Exception:  # a twin bug must not crash the firmware: report it as a bus error
            self.i2c_errors += 1
            log.exception("twin raised inside an I2C transfer")
            return native.I2C_BUS_ERROR

    def _window(self, _user, sensor, t0, t1, conf, counts, saturated):  # type: ignore[no-untyped-def]
        """Counts of a completed window for the native models (the plan did not have it)."""
        try:
            self._flush_duties()
            self._sync_plan()
            cfg = self._confs.get(conf)
            if cfg is None:
                cfg = self._confs[conf] = (SensorConfig.from_conf(conf), bool(conf & SD_ALS))
            values, sat = self.rig.read_window(sensor, t0, t1, cfg[0], sd_als=cfg[1])
            for i, v in enumerate(values.tolist()):
                counts[i] = v
            saturated[0] = sat
            return 0
        except Exception:  # a twin bug must not crash the firmware: report it as a bus error
            self.i2c_errors += 1
            log.exception("twin raised computing a window's counts")
            return 1
        finally:
            self._push_plan()

    def _sync_plan(self) -> None:
        """Tell the twin which plan entries the library handed out since the last push."""
        if self._pushed is not None and self._pushed is self.rig.plan:
            self.lib.stac_sim_plan_progress(self._ptr, self._next, ctypes.byref(self._evaluated))
            self.rig.plan_progress(list(self._next), self._evaluated.value)

    def _push_plan(self) -> None:
        plan = self.rig.plan
        if plan is None and self._pushed is None:
            return
        self._pushed = plan
        if plan is None:
            self.lib.stac_sim_plan(self._ptr, None, 0, self._next, 0)
            return
        if self._plan_rows is None or self._plan_rows[0] is not plan:
            rows = np.zeros(plan.n, native.WINDOW_DTYPE)
            rows["t0_us"] = [k[0] for k in plan.keys]
            rows["t1_us"] = [k[1] for k in plan.keys]
            rows["conf"] = (plan.cfg.to_conf() | (SD_ALS if plan.sd_als else 0)) & (
                native.WINDOW_BITS
            )
            rows["counts"] = plan.counts
            rows["saturated"] = plan.saturated
            self._plan_rows = (plan, rows)
        rows = self._plan_rows[1]
        self._next[:] = plan.next
        self.lib.stac_sim_plan(self._ptr, rows.ctypes.data, plan.n, self._next, plan.evaluated)

    def _pwm(self, _user, now32, led, colour, duty):  # type: ignore[no-untyped-def]
        try:
            now = self._t64(now32)
            if self._duties_dirty_at is not None and now != self._duties_dirty_at:
                self._flush_duties()  # an earlier batch: its duties held from its own time
            self._duties[led, colour] = duty / 1000.0
            if self._duties_dirty_at is None:
                self._duties_dirty_at = now
        except Exception:
            log.exception("bad PWM call from the firmware")

    def _flush_duties(self) -> None:
        """Hand a batch of PWM changes (the core sets nine channels at once) to the twin."""
        if self._duties_dirty_at is not None:
            self.rig.set_led_duties(self._duties_dirty_at, self._duties.copy())
            self._duties_dirty_at = None

    def _tx(self, _user, now32, data, length):  # type: ignore[no-untyped-def]
        try:
            sink = self.on_tx
            if sink is None:
                return length
            taken = sink(ctypes.string_at(data, length), self._t64(now32))
            return 0 if taken is False else length
        except Exception:
            log.exception("transmit sink raised")
            return 0
