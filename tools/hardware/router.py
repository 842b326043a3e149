"""A small two-layer grid maze router (A* with vias) for the sensor board.

The board has 27 nets and ~70 pads on a 19.2 mm disc, too many to hand-place traces in code
and too few to justify an external autorouter (none is packaged for this machine). Pads,
traces and vias become obstacle fields on a fine grid; each net is grown as a tree, one A*
search per pad, with the fields of every other net as walls. Nothing here imports pcbnew:
the caller hands in plain shapes and gets plain segments and vias back.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field

import numpy as np

LAYERS = 2  # 0 = F.Cu (top), 1 = B.Cu (bottom)


@dataclass(frozen=True)
class Rules:
    pitch: float = 0.05
    track: float = 0.15
    clearance: float = 0.15
    via_diameter: float = 0.6
    via_drill: float = 0.3
    edge_clearance: float = 0.3
    margin: float = 0.03  # grid points are checked, not the segments between them
    via_cost: float = 1.5  # mm of trace a via is worth


@dataclass(frozen=True)
class Shape:
    """A piece of copper: a rotated rectangle, a circle or a round-ended segment."""

    net: str
    layers: tuple[int, ...]
    kind: str  # "rect" | "circle" | "segment"
    x: float
    y: float
    a: float = 0.0  # rect: half length along its axis; circle: radius; segment: x2
    b: float = 0.0  # rect: half width; segment: y2
    angle: float = 0.0  # rect: degrees, KiCad convention (y down, CCW on screen)
    width: float = 0.0  # segment: full width

    def distance(self, px: np.ndarray, py: np.ndarray) -> np.ndarray:
        """Signed distance from points to this copper (negative inside)."""
        if self.kind == "circle":
            return np.hypot(px - self.x, py - self.y) - self.a
        if self.kind == "segment":
            dx, dy = self.a - self.x, self.b - self.y
            length2 = dx * dx + dy * dy
            t = np.zeros_like(px) if length2 == 0 else np.clip(
                ((px - self.x) * dx + (py - self.y) * dy) / length2, 0.0, 1.0)
            return np.hypot(px - (self.x + t * dx), py - (self.y + t * dy)) - self.width / 2
        # KiCad rotates counter-clockwise on screen, i.e. clockwise in y-down coordinates.
        c, s = math.cos(math.radians(self.angle)), math.sin(math.radians(self.angle))
        lx = (px - self.x) * c - (py - self.y) * s
        ly = (px - self.x) * s + (py - self.y) * c
        qx, qy = np.abs(lx) - self.a, np.abs(ly) - self.b
        outside = np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0))
        return outside + np.minimum(np.maximum(qx, qy), 0.0)

    def reach(self) -> float:
        """Radius of a circle around (x, y) that holds the whole shape."""
        if self.kind == "circle":
            return self.a
        if self.kind == "segment":
            return math.hypot(self.a - self.x, self.b - self.y) + self.width / 2
        return math.hypot(self.a, self.b)

    def centre(self) -> tuple[float, float]:
        if self.kind == "segment":
            return (self.x + self.a) / 2, (self.y + self.b) / 2
        return self.x, self.y


@dataclass
class Route:
    net: str
    segments: list[tuple[float, float, float, float, int]] = field(default_factory=list)
    vias: list[tuple[float, float]] = field(default_factory=list)


class RoutingError(RuntimeError):
    def __init__(self, message: str, net: str = "") -> None:
        super().__init__(message)
        self.net = net


class Router:
    """Grid over a disc of `radius` around (cx, cy); obstacles are kept per net and layer."""

    def __init__(self, cx: float, cy: float, radius: float, rules: Rules) -> None:
        self.rules = rules
        self.n = math.ceil(2 * radius / rules.pitch) + 1
        self.x0, self.y0 = cx - radius, cy - radius
        axis = np.arange(self.n) * rules.pitch
        self.gx, self.gy = np.meshgrid(self.x0 + axis, self.y0 + axis)
        r = np.hypot(self.gx - cx, self.gy - cy)
        half_track = rules.track / 2
        self.edge_track = r > radius - rules.edge_clearance - half_track - rules.margin
        self.edge_via = r > radius - rules.edge_clearance - rules.via_diameter / 2 - rules.margin
        # Counts of other-net copper too close for a trace / a via, per layer; own-net counts
        # are subtracted at routing time, so a net may touch its own copper.
        shape = (LAYERS, self.n, self.n)
        self.track_block = np.zeros(shape, np.int16)
        self.via_block = np.zeros(shape, np.int16)
        self.own_track: dict[str, np.ndarray] = {}
        self.own_via: dict[str, np.ndarray] = {}
        # Vias keep off every pad, own net included: a via in an SMD pad wicks the solder away.
        self.pad_via_block = np.zeros((self.n, self.n), np.int16)
        self.pads: dict[str, list[Shape]] = {}
        self.routes: list[Route] = []

    # -- obstacles -------------------------------------------------------------------------
    def _window(self, s: Shape, grow: float) -> tuple[slice, slice]:
        cx, cy = s.centre()
        reach = s.reach() + grow + self.rules.pitch
        i0 = max(0, int((cy - reach - self.y0) / self.rules.pitch))
        i1 = min(self.n, int((cy + reach - self.y0) / self.rules.pitch) + 2)
        j0 = max(0, int((cx - reach - self.x0) / self.rules.pitch))
        j1 = min(self.n, int((cx + reach - self.x0) / self.rules.pitch) + 2)
        return slice(i0, i1), slice(j0, j1)

    def add(self, s: Shape, is_pad: bool = False) -> None:
        ru = self.rules
        grow_track = ru.clearance + ru.track / 2 + ru.margin
        grow_via = ru.clearance + ru.via_diameter / 2 + ru.margin
        win = self._window(s, grow_via)
        d = s.distance(self.gx[win], self.gy[win])
        if s.net not in self.own_track:
            self.own_track[s.net] = np.zeros_like(self.track_block)
            self.own_via[s.net] = np.zeros_like(self.via_block)
        for layer in s.layers:
            t = (d < grow_track).astype(np.int16)
            v = (d < grow_via).astype(np.int16)
            self.track_block[layer][win] += t
            self.own_track[s.net][layer][win] += t
            self.via_block[layer][win] += v
            self.own_via[s.net][layer][win] += v
        if is_pad:
            self.pads.setdefault(s.net, []).append(s)
            self.pad_via_block[win] += (d < grow_via).astype(np.int16)

    def keep_vias_out(self, s: Shape) -> None:
        """Forbid vias over an area (silkscreen labels stay legible); traces may pass."""
        grow = self.rules.via_diameter / 2 + self.rules.margin
        win = self._window(s, grow)
        self.pad_via_block[win] += (s.distance(self.gx[win], self.gy[win]) < grow).astype(
            np.int16)

    # -- search ----------------------------------------------------------------------------
    def _free(self, net: str) -> tuple[np.ndarray, np.ndarray]:
        own_t = self.own_track.get(net, np.zeros_like(self.track_block))
        own_v = self.own_via.get(net, np.zeros_like(self.via_block))
        track_ok = ((self.track_block - own_t) == 0) & ~self.edge_track
        via_ok = ((self.via_block - own_v) == 0).all(axis=0) & ~self.edge_via
        via_ok &= self.pad_via_block == 0
        return track_ok, via_ok

    def _pad_nodes(self, s: Shape) -> set[int]:
        win = self._window(s, 0.0)
        inside = s.distance(self.gx[win], self.gy[win]) < -0.02
        ii, jj = np.nonzero(inside)
        nodes = set()
        for layer in s.layers:
            base = layer * self.n * self.n
            for i, j in zip(ii + win[0].start, jj + win[1].start, strict=True):
                nodes.add(base + int(i) * self.n + int(j))
        return nodes

    def _astar(self, sources: set[int], targets: set[int], track_ok: np.ndarray,
               via_ok: np.ndarray, goal: tuple[float, float]) -> list[int]:
        n, nn = self.n, self.n * self.n
        free = track_ok.reshape(-1).tolist()
        via_free = via_ok.reshape(-1).tolist()
        via_steps = self.rules.via_cost / self.rules.pitch
        gi, gj = goal
        steps = [(-1, 0, 1.0), (1, 0, 1.0), (0, -1, 1.0), (0, 1, 1.0),
                 (-1, -1, math.sqrt(2)), (-1, 1, math.sqrt(2)), (1, -1, math.sqrt(2)),
                 (1, 1, math.sqrt(2))]

        def h(node: int) -> float:
            rem = node % nn
            di, dj = abs(rem // n - gi), abs(rem % n - gj)
            return max(di, dj) + (math.sqrt(2) - 1) * min(di, dj)

        best: dict[int, float] = {}
        parent: dict[int, int] = {}
        heap: list[tuple[float, float, int]] = []
        for s in sources:  # tree copper: free for this net even where others' fields reach
            best[s] = 0.0
            heapq.heappush(heap, (h(s), 0.0, s))
        while heap:
            _, g, node = heapq.heappop(heap)
            if g > best.get(node, math.inf):
                continue
            if node in targets:
                path = [node]
                while path[-1] in parent:
                    path.append(parent[path[-1]])
                return path[::-1]
            layer, rem = divmod(node, nn)
            i, j = divmod(rem, n)
            moves = []
            for di, dj, cost in steps:
                ii, jj = i + di, j + dj
                if 0 <= ii < n and 0 <= jj < n:
                    moves.append((layer * nn + ii * n + jj, cost))
            if via_free[rem]:
                moves.append(((1 - layer) * nn + rem, via_steps))
            for nxt, cost in moves:
                if not (free[nxt] or nxt in targets):
                    continue
                ng = g + cost
                if ng < best.get(nxt, math.inf):
                    best[nxt] = ng
                    parent[nxt] = node
                    heapq.heappush(heap, (ng + h(nxt), ng, nxt))
        raise RoutingError("no path")

    def _to_route(self, net: str, path: list[int]) -> Route:
        n, nn, p = self.n, self.n * self.n, self.rules.pitch
        route = Route(net)
        pts = [(node // nn, (node % nn) // n, node % n) for node in path]
        start = pts[0]
        prev = pts[0]
        direction: tuple[int, int] | None = None
        for cur in pts[1:]:
            if cur[0] != prev[0]:  # layer change: close the run, drop a via
                if prev != start:
                    route.segments.append(self._seg(start, prev))
                route.vias.append((self.x0 + prev[2] * p, self.y0 + prev[1] * p))
                start, prev, direction = cur, cur, None
                continue
            step = (cur[1] - prev[1], cur[2] - prev[2])
            if direction is not None and step != direction:
                route.segments.append(self._seg(start, prev))
                start = prev
            direction = step
            prev = cur
        if prev != start:
            route.segments.append(self._seg(start, prev))
        return route

    def _seg(self, a: tuple[int, int, int], b: tuple[int, int, int]
             ) -> tuple[float, float, float, float, int]:
        p = self.rules.pitch
        return (self.x0 + a[2] * p, self.y0 + a[1] * p, self.x0 + b[2] * p, self.y0 + b[1] * p,
                a[0])

    def _commit(self, route: Route) -> set[int]:
        """Make a new route an obstacle for other nets; return its grid nodes."""
        ru = self.rules
        nodes: set[int] = set()
        for x1, y1, x2, y2, layer in route.segments:
            s = Shape(route.net, (layer,), "segment", x1, y1, x2, y2, width=ru.track)
            self.add(s)
            nodes |= self._pad_nodes(Shape(route.net, (layer,), "segment", x1, y1, x2, y2,
                                           width=0.05))
        for x, y in route.vias:
            self.add(Shape(route.net, (0, 1), "circle", x, y, ru.via_diameter / 2))
            nodes |= self._pad_nodes(Shape(route.net, (0, 1), "circle", x, y, 0.03))
        self.routes.append(route)
        return nodes

    def route_net(self, net: str) -> None:
        pads = sorted(self.pads.get(net, []), key=lambda s: (s.x, s.y))
        if len(pads) < 2:
            return
        tree = self._pad_nodes(pads[0])
        tree_pts = [pads[0].centre()]
        todo = pads[1:]
        while todo:
            # Join the pad nearest to what is already connected: short, local branches.
            todo.sort(key=lambda s: min(math.dist(s.centre(), t) for t in tree_pts))
            pad = todo.pop(0)
            track_ok, via_ok = self._free(net)
            targets = self._pad_nodes(pad)
            goal = ((pad.y - self.y0) / self.rules.pitch, (pad.x - self.x0) / self.rules.pitch)
            try:
                path = self._astar(tree, targets, track_ok, via_ok, goal)
            except RoutingError as exc:
                raise RoutingError(f"net {net}: cannot reach pad at ({pad.x:.2f}, "
                                   f"{pad.y:.2f})", net) from exc
            route = self._to_route(net, path)
            tree |= self._commit(route) | targets
            tree_pts.append(pad.centre())
            tree_pts.extend(((x1 + x2) / 2, (y1 + y2) / 2) for x1, y1, x2, y2, _ in
                            route.segments)


def route_all(cx: float, cy: float, radius: float, rules: Rules, pads: list[Shape],
              order: list[str], no_via: list[Shape], attempts: int = 40) -> Router:
    """Route every net; when one gets walled in, start over with it first (rip-up by restart).

    Deterministic: the same pads and order always give the same board.
    """
    order = list(order)
    last: RoutingError | None = None
    for _ in range(attempts):
        router = Router(cx, cy, radius, rules)
        for pad in pads:
            router.add(pad, is_pad=True)
        for area in no_via:
            router.keep_vias_out(area)
        try:
            for net in order:
                router.route_net(net)
            return router
        except RoutingError as exc:
            last = exc
            order.remove(exc.net)
            order.insert(0, exc.net)
    raise RoutingError(f"gave up after {attempts} orders: {last}")
