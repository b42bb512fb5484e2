#!/usr/bin/env python3
"""Readers nobody here wrote agree with `vio export --format mcap`.

Exports one scenario twice, as an EuRoC ASL folder and as a ROS 2 bag (MCAP), then reads the
bag with Foxglove's Python `mcap` reader and `mcap-ros2-support`'s decoder (which decodes CDR
from the message definitions embedded in the bag, as Foxglove and rosbag2 tools do) and checks
it against the folder: the topics and their types, the message counts, every header stamp
against its log time and the CSV stamps, every IMU sample and ground-truth pose value for
value, the feature tracks row for row, images (first, middle, last of each camera) pixel for
pixel against the PNGs, each CameraInfo against `sensor.yaml`, /tf_static against `T_BS`, and
the attached Kalibr files byte for byte against the folder's. Exit 1 naming what differs.

    python3 tools/check_bag.py [--vio target/release/vio] [--scenario NAME] [--duration S]

Needs `pip install -r tools/requirements-bag-check.txt` (mcap, mcap-ros2-support, PyYAML,
Pillow)."""

import argparse
import csv
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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vio", default="target/release/vio")
    ap.add_argument("--scenario", default="room_figure8_rendered_stereo_imu")
    ap.add_argument("--duration", default="10")
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

        messages = defaultdict(list)  # topic -> [(log_time, decoded)]
        types = {}
        with open(bag, "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            header = reader.get_header()
            check(header.profile == "ros2", f"profile {header.profile!r}, expected 'ros2'")
            summary = reader.get_summary()
            for ch in summary.channels.values():
                schema = summary.schemas[ch.schema_id]
                types[ch.topic] = schema.name
                check(schema.encoding == "ros2msg", f"{ch.topic}: schema encoding {schema.encoding}")
                check(ch.message_encoding == "cdr", f"{ch.topic}: message encoding {ch.message_encoding}")
            attachments = {a.name: a.data for a in reader.iter_attachments()}
            for _, channel, message, msg in reader.iter_decoded_messages(log_time_order=True):
                messages[channel.topic].append((message.log_time, msg))

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
    if FAILURES:
        for f in FAILURES[:30]:
            print(f"check_bag: {f}", file=sys.stderr)
        print(f"check_bag: {len(FAILURES)} differences", file=sys.stderr)
        return 1
    print("check_bag: mcap + mcap-ros2-support read the bag as the ASL folder says: "
          + ", ".join(f"{t} {n}" for t, n in sorted(counts.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
