"""The ROS 2 bag export benchmark runs end to end on a small scale (no timing is asserted)."""

from __future__ import annotations


def test_rosbag_bench_json(run_bench) -> None:
    figures = run_bench("rosbag", "--samples", "400", "--ft-rate", "100", "--rounds", "1")
    assert set(figures) == {
        "export rosbag, sqlite3",
        "export rosbag, mcap",
        "WrenchStamped payloads",
    }
    export = figures["export rosbag, sqlite3"]
    # every optical sample and F/T row is a message
    assert export["extra"]["messages"] == export["extra"]["samples"] + export["extra"]["ft_samples"]
    assert export["value"] > 0 and export["reference_value"] > 0
    assert figures["WrenchStamped payloads"]["ratio"] > 0
