#!/usr/bin/env python3
"""Opens a run's `run.mcap` in the Rerun viewer with a layout for it.

Rerun imports the bag as it is (the 3D scene, the tracks picture and the events appear with no
configuration); what a bag cannot say is which message fields to plot over time. This script
writes that as a Rerun blueprint: the 3D view in frame `world` (estimate and ground-truth trails,
the window's points and frames), the tracks picture, plots of the aligned position error, the
time offset, the back end's time and the landmark count, and the events.

    python3 tools/rerun_view.py vio-out/room_figure8_stereo_imu/run.mcap
    python3 tools/rerun_view.py RUN.mcap --screenshot shot.png   # under Xvfb, see docs/src/ros2.md

Needs `rerun-sdk` (tested with 0.41.0: component mappings are still marked experimental there).
Exit status 2 with a message for a file that is missing or not a run bag.
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile

APP_ID = "vio_run"

# (entity, title, ROS 2 message component, [(series name, field selector)])
PLOTS = [
    (
        "/estimate/position_error",
        "position error, aligned (m)",
        "geometry_msgs.msg.Vector3Stamped:message",
        [("x", ".vector.x"), ("y", ".vector.y"), ("z", ".vector.z")],
    ),
    (
        "/estimate/time_offset_ms",
        "time offset (ms)",
        "std_msgs.msg.Float64:message",
        [("td", ".data")],
    ),
    (
        "/timing/backend_ms",
        "back end per estimate (ms)",
        "std_msgs.msg.Float64:message",
        [("back end", ".data")],
    ),
    (
        "/estimate/landmarks",
        "landmarks in the window",
        "std_msgs.msg.Float64:message",
        [("landmarks", ".data")],
    ),
]

# Entity → (colour RGBA, radius in m) of the point clouds in the 3D view.
CLOUDS = {
    "/estimate/trail": ([255, 140, 0, 255], 0.004),
    "/groundtruth/trail": ([200, 200, 200, 255], 0.009),
    "/window/points": ([0, 190, 255, 255], 0.015),
}


def fail(message):
    print(f"rerun_view: {message}", file=sys.stderr)
    sys.exit(2)


def blueprint():
    """The layout: 3D on the left, the picture, the plots and the events on the right."""
    import rerun as rr
    import rerun.blueprint as rrb
    from rerun.blueprint.encodings import VisualizerComponentMapping as Mapping

    def series(component, fields):
        return [
            rr.SeriesLines(names=[name]).visualizer(
                mappings=[
                    Mapping(
                        "Scalars:scalars",
                        "SourceComponent",
                        source_component=component,
                        selector=selector,
                    )
                ]
            )
            for name, selector in fields
        ]

    plots = [
        rrb.TimeSeriesView(
            origin=entity,
            name=title,
            overrides={entity: series(component, fields)},
        )
        for entity, title, component, fields in PLOTS
    ]
    clouds = {
        entity: rr.Points3D.from_fields(colors=[colour], radii=[radius]).visualizer()
        for entity, (colour, radius) in CLOUDS.items()
    }
    scene = rrb.Spatial3DView(
        origin="/",
        name="world",
        contents=["/estimate/trail", "/groundtruth/trail", "/window/**", "/tf/**"],
        spatial_information=rrb.SpatialInformation(target_frame="world", axes=rr.ViewCoordinates.RIGHT_HAND_Z_UP),
        overrides=clouds,
    )
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                scene,
                rrb.TextLogView(origin="/rosout", name="events"),
                row_shares=[4, 1],
            ),
            rrb.Vertical(
                rrb.Spatial2DView(origin="/cam0/tracks", name="tracks (cam0)"),
                rrb.Grid(*plots, grid_columns=2),
                row_shares=[1, 1],
            ),
            column_shares=[1, 1],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", play_state="following"),
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run_mcap", help="a run.mcap written by vio run/euroc/bag --mcap")
    parser.add_argument("--screenshot", help="save a screenshot here and exit")
    parser.add_argument("--window-size", default="1600x1000")
    parser.add_argument(
        "--renderer",
        default=None,
        help="the viewer's wgpu back end (vulkan under Xvfb with Mesa)",
    )
    args = parser.parse_args()
    if not os.path.isfile(args.run_mcap):
        fail(f"{args.run_mcap}: no such file")
    with open(args.run_mcap, "rb") as f:
        if f.read(8) != b"\x89MCAP0\r\n":
            fail(f"{args.run_mcap}: not an MCAP file")
    rerun = shutil.which("rerun")
    if rerun is None:
        fail("the rerun viewer is not installed (pip install rerun-sdk==0.41.0)")
    with tempfile.TemporaryDirectory(prefix="vio-rerun-") as tmp:
        rrd = os.path.join(tmp, "run.rrd")
        rbl = os.path.join(tmp, "run.rbl")
        convert = [rerun, "mcap", "convert", args.run_mcap, "--application-id", APP_ID, "-o", rrd]
        done = subprocess.run(convert, capture_output=True, text=True)
        if done.returncode != 0:
            fail(f"{args.run_mcap}: rerun could not import it: {done.stderr.strip()[-400:]}")
        blueprint().save(APP_ID, rbl)
        view = [rerun, rrd, rbl, "--window-size", args.window_size]
        if args.renderer:
            view += ["--renderer", args.renderer]
        if args.screenshot:
            view += ["--screenshot-to", os.path.abspath(args.screenshot)]
        sys.exit(subprocess.run(view).returncode)


if __name__ == "__main__":
    main()
