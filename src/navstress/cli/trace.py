"""``navstress trace export``: a run's trace for other tools (the ``trace`` group)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from navstress._console import literal
from navstress.errors import SpecError
from navstress.run.ros2 import export_ros2

app = typer.Typer(rich_markup_mode=None)
trace_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None,
                        help="Export a run's trace to other tools (a ROS 2 bag for RViz).")
app.add_typer(trace_app, name="trace")

FORMATS = ("ros2",)


@trace_app.command("export")
def trace_export(
    trace: Annotated[Path, typer.Argument(metavar="TRACE", help="A run's trace (.mcap), as navstress wrote it.")],
    output: Annotated[Path, typer.Option("--output", "-o", metavar="DIR", help=(
        "The ROS 2 bag to write: a new directory (metadata.yaml and the MCAP file of the bag)."))],
    fmt: Annotated[str, typer.Option("--format", "-f", metavar="|".join(FORMATS), help=(
        "ros2: a rosbag2 (MCAP storage) with standard ROS 2 messages (tf2_msgs/TFMessage, nav_msgs/Odometry, "
        "sensor_msgs/PointCloud2, visualization_msgs/MarkerArray, nav_msgs/OccupancyGrid, rcl_interfaces/Log) "
        "for `ros2 bag play` and RViz (on Humble, install its MCAP storage plugin first: "
        "ros-humble-rosbag2-storage-mcap)."))] = "ros2",
) -> None:
    """Export a run's trace to another tool's format."""
    if fmt.lower() not in FORMATS:
        raise SpecError("--format", fmt, f"one of {', '.join(FORMATS)}")
    if output.exists() or output.is_symlink():
        raise SpecError("--output", str(output), "a path that does not exist yet (a ROS 2 bag is a new directory)")
    counts = export_ros2(trace, output)
    typer.echo(literal(f"wrote {output} ({sum(counts.values())} messages on {len(counts)} topics)"))
