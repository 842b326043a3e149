"""live_guard's newer limits: each probe refuses every attempt against the live server
(binary frames, a compressed frame, framing headers, slow headers, the connection cap), and
the figures follow the benchmark convention (a ratio to the attempts of the same run)."""

from __future__ import annotations

from tools.bench.live_guard import LIMIT_NAMES, figures, newer_limits


def test_every_newer_limit_refuses_every_attempt() -> None:
    limits = newer_limits()
    assert set(limits) == set(LIMIT_NAMES)
    for name, got in limits.items():
        assert got["tried"] >= 1 and got["refused"] == got["tried"], (name, got)
    assert limits["slow_headers"]["counted"] == limits["slow_headers"]["tried"]
    assert limits["over_cap"]["counted"] == limits["over_cap"]["tried"]
    compressed = limits["compressed_frame"]
    assert compressed["rss_after_mb"] - compressed["rss_before_mb"] < 30  # never inflated
    # the bench's other parts as fixed figures, so that only the newer limits' rows vary here
    refused_all = {"tried": 1, "refused": 1}
    out = {"hostile": refused_all, "post_400mb": {"rss_after_mb": 1, "rss_before_mb": 1},
           "message_16mb": {"watcher_max_gap_ms": 5}, "limits": limits,
           "joins": {"joins": 1, "duplicate_or_out_of_order": 0}}  # fmt: skip
    shown = {f.name: f for f in figures(out)}
    for name in LIMIT_NAMES.values():
        assert shown[f"{name} refused"].ratio == 1.0
