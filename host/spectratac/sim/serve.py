"""Expose a simulated device to other programs as a serial port (pty) or a TCP socket.

    spectratac sim serve --pty [--link /tmp/spectratac0]   # then open /tmp/spectratac0
    spectratac sim serve --tcp 5555                       # then open socket://127.0.0.1:5555

The pty behaves like a USB-serial adapter: the device is silent until asked, and bytes the
device sends while nobody reads are dropped (counted by the firmware). SIGUSR1 simulates
unplugging the adapter: the pty disappears, and after --replug-after seconds a new one
(a freshly booted device) appears behind the same --link path. --link only ever replaces a
symlink (never a regular file or folder someone keeps there) and is removed when serving ends,
by SIGINT, SIGTERM or an error.
"""

from __future__ import annotations

import contextlib
import errno
import os
import select
import signal
import socket
import threading
import time
import tty
from collections.abc import Callable
from pathlib import Path

from spectratac.errors import SpectraTacError
from spectratac.record.stop import AnyStop, SignalFlag, StopFlag, StopRequest, stop_handler
from spectratac.sim.device import SimDevice
from spectratac.sim.faults import FaultLayer
from spectratac.sim.model_store import store_path
from spectratac.sim.named_scenes import make_scene, scene_settings
from spectratac.sim.runner import MAX, DeviceRunner
from spectratac.sim.url import SimOptions


class LinkPathTaken(SpectraTacError):
    """--link names something that is not a symlink: serving would destroy it."""


def check_link_path(link: Path) -> None:
    """Refuse a --link path that exists and is not a symlink (a file, folder, device...)."""
    if link.is_symlink() or not os.path.lexists(link):
        return
    raise LinkPathTaken(
        f"--link {link} exists and is not a symlink; sim serve only replaces a symlink it may "
        f"have left: move that file away or choose another --link path"
    )


def _remove_link(link: Path, target: str | None) -> None:
    """Remove `link` if it is still the symlink this server made (to `target`)."""
    with contextlib.suppress(OSError):
        if link.is_symlink() and (target is None or os.readlink(link) == target):
            link.unlink()


class _Endpoint:
    """The current file descriptor the device talks through (pty master or socket)."""

    def __init__(self, blocking_writes: bool) -> None:
        self.fd: int | None = None
        self.blocking = blocking_writes
        self.lock = threading.Lock()

    def send(self, data: bytes, _t: int) -> bool:
        view = memoryview(data)
        deadline = time.monotonic() + (5.0 if self.blocking else 0.0)
        while view:
            with self.lock:
                fd = self.fd
                if fd is None:
                    return False
                try:
                    view = view[os.write(fd, view) :]
                    continue
                except BlockingIOError:
                    pass
                except OSError:
                    return False
            if time.monotonic() >= deadline:
                return False  # nobody reads: the device counts the frame as dropped
            select.select([], [fd], [], 0.05)
        return True


class _FaultyRunner(DeviceRunner):
    """A device behind a fault layer (``fault=`` in its sim URL): host bytes pass the layer."""

    layer: FaultLayer

    def write(self, data: bytes) -> None:
        self.layer.from_host(data)

    def stop(self) -> None:
        self.layer.close()
        super().stop()


def _boot(opts: SimOptions, endpoint: _Endpoint) -> DeviceRunner:
    scene = make_scene(opts.scene, seed=str(opts.seed), **opts.scene_params)
    if not opts.faults:
        device = SimDevice(
            scene,
            opts.seed,
            absent=opts.absent,
            on_tx=endpoint.send,
            baud=921_600,
            model_store=store_path(opts.model_store, opts.seed),
            settings=scene_settings(opts.scene),
        )
        return DeviceRunner(device, opts.speed).start()
    runner: _FaultyRunner
    layer = FaultLayer(
        opts.query(),
        opts.faults,
        opts.fault_params,
        opts.seed,
        endpoint.send,
        lambda data: DeviceRunner.write(runner, data),
    )
    device = SimDevice(
        scene,
        opts.seed,
        absent=opts.absent,
        on_tx=layer.from_device,
        baud=921_600,
        model_store=store_path(opts.model_store, opts.seed),
        settings=scene_settings(opts.scene),
    )
    runner = _FaultyRunner(device, opts.speed)
    runner.layer = layer
    return runner.start()


def _open_pty(link: Path | None) -> tuple[int, str]:
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    os.close(slave)  # the host opens it by name; keeping it closed lets EIO signal "no host"
    os.set_blocking(master, False)
    if link is not None:
        check_link_path(link)  # again: something may have been put there while unplugged
        tmp = link.with_name(link.name + ".new")
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        tmp.symlink_to(path)
        tmp.replace(link)
    return master, path


def _signal_stop(stop: StopFlag | None) -> StopFlag:
    """`stop` (set by the caller from another thread), or SIGTERM or SIGINT in the main
    thread: the handler sets a lock-free StopRequest, never an Event (it could deadlock
    there). SIGINT too, rather than a KeyboardInterrupt raised wherever the main thread is
    (between booting a device and its clean-up, say: a Ctrl-C right after the announcement
    then left the server hanging on a loaded machine); a second Ctrl-C still interrupts.
    The request's pipe lives as long as the process serves, which is until it exits."""
    if threading.current_thread() is not threading.main_thread():
        return stop or threading.Event()
    signalled = StopRequest()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, stop_handler(signalled))
    return signalled if stop is None else AnyStop(stop, signalled)


def serve_pty(
    opts: SimOptions,
    link: Path | None = None,
    replug_after: float = 1.0,
    announce: Callable[[str], None] = print,
    stop: StopFlag | None = None,
) -> None:
    """Serve until SIGINT/SIGTERM (or `stop` is set); SIGUSR1 unplugs and replugs. `link`
    must not be an existing non-symlink (LinkPathTaken); it is removed when serving ends."""
    if link is not None:
        check_link_path(link)
    stop = _signal_stop(stop)
    unplug = SignalFlag()  # a handler sets it: no lock (Event.set could deadlock there)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGUSR1, lambda *_: unplug.set())
    endpoint = _Endpoint(opts.speed == MAX)
    path: str | None = None
    try:
        while not stop.is_set():
            master, path = _open_pty(link)
            endpoint.fd = master
            runner = _boot(opts, endpoint)
            announce(path)
            try:
                _pump_pty(master, runner, stop, unplug)
            finally:
                runner.stop()
                with endpoint.lock:
                    endpoint.fd = None
                    os.close(master)
            if unplug.is_set():
                unplug.clear()
                if link is not None:
                    _remove_link(link, path)
                stop.wait(replug_after)
    finally:  # SIGINT or SIGTERM (stop), a second SIGINT or an error: leave no link behind
        if link is not None and path is not None:
            _remove_link(link, path)


def _pump_pty(master: int, runner: DeviceRunner, stop: StopFlag, unplug: SignalFlag) -> None:
    while not stop.is_set() and not unplug.is_set():
        readable, _, _ = select.select([master], [], [], 0.1)
        if not readable:
            continue
        try:
            data = os.read(master, 65536)
        except BlockingIOError:
            continue
        except OSError as exc:  # EIO: no host has the pty open right now
            if exc.errno != errno.EIO:
                raise
            time.sleep(0.02)
            continue
        runner.write(data)


def serve_tcp(
    opts: SimOptions,
    port: int,
    host: str = "127.0.0.1",
    announce: Callable[[str], None] = print,
    stop: StopFlag | None = None,
) -> None:
    """Serve one client at a time on host:port; each connection talks to the same device."""
    stop = _signal_stop(stop)
    endpoint = _Endpoint(opts.speed == MAX)
    runner = _boot(opts, endpoint)
    with socket.create_server((host, port), reuse_port=False) as server:
        server.settimeout(0.2)
        announce(f"socket://{host}:{server.getsockname()[1]}")
        try:
            while not stop.is_set():
                try:
                    conn, _ = server.accept()
                except TimeoutError:
                    continue
                with conn:
                    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                    conn.setblocking(False)
                    with endpoint.lock:
                        endpoint.fd = conn.fileno()
                    _pump_socket(conn, runner, stop)
                    with endpoint.lock:
                        endpoint.fd = None
        finally:
            runner.stop()


def _pump_socket(conn: socket.socket, runner: DeviceRunner, stop: StopFlag) -> None:
    while not stop.is_set():
        readable, _, _ = select.select([conn], [], [], 0.1)
        if not readable:
            continue
        try:
            data = conn.recv(65536)
        except BlockingIOError:
            continue
        except OSError:
            return
        if not data:
            return  # the client closed the connection
        runner.write(data)
