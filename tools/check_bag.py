#!/usr/bin/env python3
"""Readers nobody here wrote agree with `vio export --format mcap`.

Exports one scenario twice, as an EuRoC ASL folder and as a ROS 2 bag (MCAP), then reads the
bag with Foxglove's Python `mcap` reader and `mcap-ros2-support`'s decoder (which decodes CDR
from the message definitions embedded in the bag, as Foxglove and rosbag2 tools do) and checks
it against the folder: the topics and their types, the message counts, every header stamp
against its log time and the CSV stamps, every IMU sample and ground-truth pose value for
value, the feature tracks row for row, images (first, middle, last of each camera) pixel for
pixel against the PNGs, each CameraInfo against `sensor.yaml`, /tf_static against `T_BS`, and
the attached Kalibr files byte for byte against the folder's.

Then runs a scenario with `vio run --mcap` and reads its `run.mcap` the same way against the
run's own files: the documented topics and types, one estimate, ground-truth pose, /tf, tracks
picture per row of `estimate.tum` at its stamp, the ground truth value for value against
`groundtruth.tum`, the position error as the estimate less the truth, the last trails holding
every estimate, the events on /rosout. Exit 1 naming what differs.

    python3 tools/check_bag.py [--vio target/release/vio] [--scenario NAME] [--duration S]
                               [--run-scenario NAME] [--run-duration S]

Needs `pip install -r tools/requirements-bag-check.txt` (mcap, mcap-ros2-support, PyYAML,
Pillow)."""

import argparse
import csv
import io
import subprocess
import sys
import tempfile
from collections import Counter, defaultdict
from pathlib import Path

import yaml
from PIL import Image
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

FAILURES = []


def check(ok, what):
    if not ok:
        FAILURES.append(what)


def rows(path):
    with open(path) as f:
        return [r for r in csv.reader(f) if r and not r[0].startswith("#") and r[0] != "t_ns"]


def stamp_ns(header):
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def read_bag(path):
    """The bag's topic types, its messages by topic as `(log_time, decoded)` in log-time order,
    and its attachments; checks the ROS 2 profile and encodings on the way."""
    messages = defaultdict(list)
    types = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        check(header.profile == "ros2", f"{path.name}: profile {header.profile!r}, expected 'ros2'")
        summary = reader.get_summary()
        for ch in summary.channels.values():
            schema = summary.schemas[ch.schema_id]
            types[ch.topic] = schema.name
            check(schema.encoding == "ros2msg", f"{ch.topic}: schema encoding {schema.encoding}")
            check(ch.message_encoding == "cdr", f"{ch.topic}: message encoding {ch.message_encoding}")
        attachments = {a.name: a.data for a in reader.iter_attachments()}
        for _, channel, message, msg in reader.iter_decoded_messages(log_time_order=True):
            messages[channel.topic].append((message.log_time, msg))
    return types, messages, attachments


def tum_rows(path):
    """`(stamp_ns, [tx, ty, tz, qx, qy, qz, qw])` of a TUM file written with 9 decimals."""
    out = []
    for line in path.read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        t, *v = line.split()
        sec, frac = t.split(".")
        out.append((int(sec) * 1_000_000_000 + int(frac.ljust(9, "0")), [float(x) for x in v]))
    return out


RUN_TOPICS = {
    "/tf": "tf2_msgs/msg/TFMessage",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/estimate/pose": "geometry_msgs/msg/PoseStamped",
    "/groundtruth/pose": "geometry_msgs/msg/PoseStamped",
    "/estimate/path": "nav_msgs/msg/Path",
    "/groundtruth/path": "nav_msgs/msg/Path",
    "/estimate/trail": "sensor_msgs/msg/PointCloud2",
    "/groundtruth/trail": "sensor_msgs/msg/PointCloud2",
    "/window/poses": "geometry_msgs/msg/PoseArray",
    "/window/points": "sensor_msgs/msg/PointCloud2",
    "/estimate/pose_with_covariance": "geometry_msgs/msg/PoseWithCovarianceStamped",
    "/estimate/position_error": "geometry_msgs/msg/Vector3Stamped",
    "/estimate/velocity": "geometry_msgs/msg/Vector3Stamped",
    "/estimate/gyro_bias": "geometry_msgs/msg/Vector3Stamped",
    "/estimate/accel_bias": "geometry_msgs/msg/Vector3Stamped",
    "/estimate/time_offset_ms": "std_msgs/msg/Float64",
    "/estimate/landmarks": "std_msgs/msg/Float64",
    "/timing/backend_ms": "std_msgs/msg/Float64",
    "/cam0/tracks": "sensor_msgs/msg/CompressedImage",
    "/rosout": "rcl_interfaces/msg/Log",
}


def check_run_bag(vio, scenario, duration, tmp):
    """`vio run --mcap`'s run.mcap against the run's estimate.tum and groundtruth.tum; returns
    the message counts by topic."""
    import struct
    out = tmp / "run"
    subprocess.run([vio, "run", scenario, "--duration", duration, "--mcap", "--out", str(out)],
                   check=True, stdout=subprocess.DEVNULL)
    types, messages, _ = read_bag(out / "run.mcap")
    check(types == RUN_TOPICS, f"run.mcap topics {sorted(types.items())}, expected {sorted(RUN_TOPICS.items())}")
    # One message per estimate: estimate.tum's rows (the tracking ones), and those before them.
    stamps = [t for t, _ in messages["/estimate/pose"]]
    tracked = [t for t, _ in tum_rows(out / "estimate.tum")]
    check(len(tracked) > 0 and stamps[len(stamps) - len(tracked):] == tracked,
          f"run.mcap /estimate/pose: {len(stamps)} estimates, estimate.tum's {len(tracked)} rows not the last of them")
    for topic in ("/groundtruth/pose", "/tf", "/estimate/position_error", "/cam0/tracks"):
        got = [t for t, _ in messages[topic]]
        check(got == stamps, f"run.mcap {topic}: {len(got)} messages, /estimate/pose {len(stamps)}; stamps differ")
    for topic in ("/estimate/pose", "/groundtruth/pose", "/estimate/position_error"):
        for t, m in messages[topic]:
            check(stamp_ns(m.header) == t, f"run.mcap {topic}: header stamp {stamp_ns(m.header)} != log time {t}")
    truth = dict(tum_rows(out / "groundtruth.tum"))
    for (t, est), (_, gt), (_, err) in zip(messages["/estimate/pose"], messages["/groundtruth/pose"],
                                           messages["/estimate/position_error"]):
        p, q = gt.pose.position, gt.pose.orientation
        check(truth.get(t) == [p.x, p.y, p.z, q.x, q.y, q.z, q.w], f"run.mcap /groundtruth/pose at {t} vs groundtruth.tum")
        e = est.pose.position
        check([err.vector.x, err.vector.y, err.vector.z] == [e.x - p.x, e.y - p.y, e.z - p.z],
              f"run.mcap /estimate/position_error at {t}")
    trails = messages["/estimate/trail"]
    check(len(trails) > 0 and trails[-1][1].width == len(stamps), "run.mcap /estimate/trail: the last holds every estimate")
    if trails and messages["/estimate/pose"]:
        last = trails[-1][1]
        x, y, z = struct.unpack_from("<fff", bytes(last.data), (last.width - 1) * last.point_step)
        e = messages["/estimate/pose"][-1][1].pose.position
        check(max(abs(x - e.x), abs(y - e.y), abs(z - e.z)) < 1e-5, "run.mcap /estimate/trail: last point vs last pose")
    for t, m in messages["/cam0/tracks"][:: max(1, len(stamps) // 5)]:
        picture = Image.open(io.BytesIO(bytes(m.data)))
        check(m.format == picture.format.lower() and picture.size == (752, 480),
              f"run.mcap /cam0/tracks at {t}: {m.format}, {picture.format} {picture.size}")
    logs = [m.msg for _, m in messages["/rosout"]]
    check(any("status_change" in text for text in logs), f"run.mcap /rosout: no status change in {logs[:3]}")
    return Counter({t: len(m) for t, m in messages.items()})


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vio", default="target/release/vio")
    ap.add_argument("--scenario", default="room_figure8_rendered_stereo_imu")
    ap.add_argument("--duration", default="10")
    ap.add_argument("--run-scenario", default="room_figure8_stereo_imu")
    ap.add_argument("--run-duration", default="6")
    args = ap.parse_args()

    with tempfile.TemporaryDirectory(prefix="vio-bag-check-") as tmp:
        tmp = Path(tmp)
        asl, bag = tmp / "asl", tmp / "run.mcap"
        for fmt, out in (("asl", asl), ("mcap", bag)):
            subprocess.run(
                [args.vio, "export", args.scenario, "--duration", args.duration,
                 "--format", fmt, "--out", str(out)],
                check=True, stdout=subprocess.DEVNULL)
        mav0 = asl / "mav0"
        cams = sorted(p.name for p in mav0.glob("cam*"))

        types, messages, attachments = read_bag(bag)

        # Topics and types.
        expected = {
            "/imu0": "sensor_msgs/msg/Imu",
            "/groundtruth/pose": "geometry_msgs/msg/PoseStamped",
            "/tf": "tf2_msgs/msg/TFMessage",
            "/tf_static": "tf2_msgs/msg/TFMessage",
            "/features": "sensor_msgs/msg/PointCloud2",
        }
        for c in cams:
            expected[f"/{c}/camera_info"] = "sensor_msgs/msg/CameraInfo"
            if rows(mav0 / c / "data.csv"):
                expected[f"/{c}/image_raw"] = "sensor_msgs/msg/Image"
        check(types == expected, f"topics {sorted(types.items())}, expected {sorted(expected.items())}")

        # Every header stamp is its log time.
        for topic, ms in messages.items():
            for t, m in ms:
                h = m.transforms[0].header if topic in ("/tf", "/tf_static") else m.header
                if topic != "/tf_static":
                    check(stamp_ns(h) == t, f"{topic}: header stamp {stamp_ns(h)} != log time {t}")

        # IMU: every sample, value for value.
        imu = rows(mav0 / "imu0/data.csv")
        got = messages["/imu0"]
        check(len(got) == len(imu), f"/imu0: {len(got)} messages, imu0/data.csv {len(imu)} rows")
        for (t, m), r in zip(got, imu):
            values = [m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z,
                      m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z]
            check(t == int(r[0]) and values == [float(x) for x in r[1:7]], f"/imu0 at {t}: {values} vs {r}")

        # Ground truth: every pose, and /tf the same.
        gt = rows(mav0 / "state_groundtruth_estimate0/data.csv")
        for topic in ("/groundtruth/pose", "/tf"):
            got = messages[topic]
            check(len(got) == len(gt), f"{topic}: {len(got)} messages, ground truth {len(gt)} rows")
        for (t, m), (_, tf), r in zip(messages["/groundtruth/pose"], messages["/tf"], gt):
            p, q = m.pose.position, m.pose.orientation
            values = [p.x, p.y, p.z, q.w, q.x, q.y, q.z]
            check(t == int(r[0]) and values == [float(x) for x in r[1:8]], f"pose at {t}: {values} vs {r[:8]}")
            tr = tf.transforms[0]
            check((tr.header.frame_id, tr.child_frame_id) == ("world", "imu0"), f"/tf frames {tr.header.frame_id}->{tr.child_frame_id}")
            check([tr.transform.translation.x, tr.transform.translation.y, tr.transform.translation.z] == values[:3], f"/tf at {t}")

        # Images: counts and stamps per camera; three of each pixel for pixel.
        for c in cams:
            listed = rows(mav0 / c / "data.csv")
            got = messages.get(f"/{c}/image_raw", [])
            check(len(got) == len(listed), f"/{c}/image_raw: {len(got)} images, data.csv {len(listed)}")
            check([t for t, _ in got] == [int(r[0]) for r in listed], f"/{c}/image_raw stamps")
            for k in sorted({0, len(got) // 2, len(got) - 1}) if got else []:
                t, m = got[k]
                png = Image.open(mav0 / c / "data" / listed[k][1])
                check(m.encoding == "mono8" and (m.width, m.height) == png.size and m.step == m.width,
                      f"/{c}/image_raw {k}: {m.encoding} {m.width}x{m.height} step {m.step}")
                check(bytes(m.data) == png.tobytes(), f"/{c}/image_raw {k}: pixels differ from {listed[k][1]}")

        # Camera infos and extrinsics against sensor.yaml.
        statics = messages["/tf_static"]
        check(len(statics) == 1, f"/tf_static: {len(statics)} messages")
        static = {tr.child_frame_id: tr for tr in statics[0][1].transforms} if statics else {}
        for c in cams:
            sensor = yaml.safe_load((mav0 / c / "sensor.yaml").read_text())
            infos = messages[f"/{c}/camera_info"]
            check(len(infos) > 0, f"/{c}/camera_info: no messages")
            for _, info in infos[:1]:
                fu, fv, cu, cv = sensor["intrinsics"][-4:]
                check(list(info.k) == [fu, 0.0, cu, 0.0, fv, cv, 0.0, 0.0, 1.0], f"/{c}/camera_info K {list(info.k)}")
                check([info.width, info.height] == sensor["resolution"], f"/{c}/camera_info size")
                d = sensor["distortion_coefficients"]
                check(list(info.d)[: len(d)] == d, f"/{c}/camera_info D {list(info.d)} vs {d}")
            tr = static.get(c)
            check(tr is not None and tr.header.frame_id == "imu0", f"/tf_static: no imu0 -> {c}")
            if tr is not None:
                t_bs = sensor["T_BS"]["data"]
                check([tr.transform.translation.x, tr.transform.translation.y, tr.transform.translation.z]
                      == [t_bs[3], t_bs[7], t_bs[11]], f"/tf_static {c} translation vs T_BS")

        # Feature tracks: every observation, in order.
        feats = rows(asl / "features.csv")
        import struct
        got = []
        for t, m in messages["/features"]:
            names = [(f.name, f.offset, f.datatype) for f in m.fields]
            check(names == [("cam_id", 0, 6), ("feature_id", 4, 6), ("u", 8, 8), ("v", 16, 8)], f"/features fields {names}")
            for k in range(m.width):
                cam, fid, u, v = struct.unpack_from("<IIdd", bytes(m.data), k * m.point_step)
                got.append((t, cam, fid, u, v))
        want = [(int(r[0]), int(r[1]), int(r[2]), float(r[3]), float(r[4])) for r in feats]
        check(sorted(got) == sorted(want), f"/features: {len(got)} observations, features.csv {len(want)}; they differ")

        # The attached Kalibr files are the folder's.
        for name in ("camchain-imucam.yaml", "imu.yaml"):
            check(attachments.get(name) == (asl / name).read_bytes(), f"attachment {name} differs from the folder's")

        counts = Counter({t: len(m) for t, m in messages.items()})
        run_counts = check_run_bag(args.vio, args.run_scenario, args.run_duration, tmp)
    if FAILURES:
        for f in FAILURES[:30]:
            print(f"check_bag: {f}", file=sys.stderr)
        print(f"check_bag: {len(FAILURES)} differences", file=sys.stderr)
        return 1
    print("check_bag: mcap + mcap-ros2-support read the bag as the ASL folder says: "
          + ", ".join(f"{t} {n}" for t, n in sorted(counts.items())))
    print(f"check_bag: and {args.run_scenario}'s run.mcap as its estimate.tum and groundtruth.tum say: "
          + ", ".join(f"{t} {run_counts[t]}" for t in ("/estimate/pose", "/estimate/trail", "/cam0/tracks", "/rosout")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
