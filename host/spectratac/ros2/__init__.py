"""ROS 2 bags out of recordings, without ROS installed (the `rosbags` package writes them).

`export_rosbag(recording, out_dir)` writes the recording's reference F/T, raw counts and,
with a decoder, its estimates as a rosbag2 bag that `ros2 bag play` replays (topics and
frames: `spectratac.ros2.export`). Bags come in through the F/T layer instead:
`rosbag://PATH?topic=…` is a reference F/T source (`spectratac.ft.rosbag`).
"""

from spectratac.ros2.errors import BagExportError
from spectratac.ros2.export import ExportSummary, export_rosbag

__all__ = ["BagExportError", "ExportSummary", "export_rosbag"]
