#!/usr/bin/env python3
"""VINS-Fusion-style stereo feature tracker (FeatureTracker::trackImage) in OpenCV/Python,
single-threaded, with per-stage timing.

Pipeline per stereo pair (cur_left, cur_right), following VINS-Fusion feature_tracker.cpp:
  1. temporal LK prev_left -> cur_left   (win 21x21, maxLevel 3, COUNT|EPS 30 0.01)
  2. flow-back LK cur_left -> prev_left  (win 21x21, maxLevel 1, USE_INITIAL_FLOW),
     keep: status fwd & bwd, |prev - back| <= 0.5 px, inBorder (1 px border)
  3. F-RANSAC rejection (VINS-Mono rejectWithF): findFundamentalMat(prev, cur, FM_RANSAC, 1.0, 0.99)
     -- run on the DISTORTED pixel coordinates by default (--undistort-f: on undistorted pixels)
  4. setMask: sort by track count desc, keep points on unmasked pixels, draw filled circles r=30
  5. goodFeaturesToTrack(cur_left, 150 - n, 0.01, 30, mask) top-up
  6. stereo LK cur_left -> cur_right (win 21x21, maxLevel 3)
  7. flow-back LK cur_right -> cur_left (win 21x21, maxLevel 3, no initial flow as in VINS-Fusion),
     keep: status both, inBorder(right), |left - back| <= 0.5 px
  (+ optional stage 'undist': cv2.undistortPoints of left and right points, as VINS does for output)

Images are read before timing; imread is not timed.

Reproduces the comparison in the README (not part of the build or the tests):
  vio export room_figure8_rendered_stereo_imu --duration 13 --out /tmp/exp
  python3 -m venv /tmp/venv && /tmp/venv/bin/pip install opencv-python-headless numpy
  /tmp/venv/bin/python scenarios/tools/opencv_vins_frontend.py /tmp/exp --repeats 5
"""
import argparse
import csv
import os
import statistics
import sys
import time

import cv2
import numpy as np

cv2.setNumThreads(1)

WIN = (21, 21)
CRIT = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 0.01)
MAX_CNT = 150
MIN_DIST = 30
FB_THRESH = 0.5
F_THRESH = 1.0
BORDER = 1

K = np.array([[458.654, 0, 367.215], [0, 457.296, 248.375], [0, 0, 1]], dtype=np.float64)
D = np.array([-0.28340811, 0.07395907, 0.00019359, 0.0000176187114], dtype=np.float64)


def in_border(pts, w, h):
    x = np.round(pts[:, 0])
    y = np.round(pts[:, 1])
    return (x >= BORDER) & (x < w - BORDER) & (y >= BORDER) & (y < h - BORDER)


class Tracker:
    def __init__(self, undistort_f=False, undist_stage=False):
        self.prev_img = None
        self.prev_pts = np.empty((0, 1, 2), np.float32)
        self.ids = np.empty(0, np.int64)
        self.track_cnt = np.empty(0, np.int64)
        self.next_id = 0
        self.undistort_f = undistort_f
        self.undist_stage = undist_stage

    def track(self, left, right):
        T = {}
        h, w = left.shape
        t0 = time.perf_counter()
        cur_pts = np.empty((0, 1, 2), np.float32)
        prev_pts = self.prev_pts
        ids, cnt = self.ids, self.track_cnt
        n_lk_in = len(prev_pts)
        # 1. temporal LK
        if len(prev_pts) > 0:
            cur_pts, st, _ = cv2.calcOpticalFlowPyrLK(self.prev_img, left, prev_pts, None,
                                                      winSize=WIN, maxLevel=3, criteria=CRIT)
            t1 = time.perf_counter(); T['lk_fwd'] = t1 - t0
            # 2. flow back
            rev = prev_pts.copy()
            rev, rst, _ = cv2.calcOpticalFlowPyrLK(left, self.prev_img, cur_pts, rev,
                                                   winSize=WIN, maxLevel=1, criteria=CRIT,
                                                   flags=cv2.OPTFLOW_USE_INITIAL_FLOW)
            d = np.linalg.norm((prev_pts - rev).reshape(-1, 2), axis=1)
            keep = (st.ravel() == 1) & (rst.ravel() == 1) & (d <= FB_THRESH) & \
                in_border(cur_pts.reshape(-1, 2), w, h)
            prev_pts, cur_pts, ids, cnt = prev_pts[keep], cur_pts[keep], ids[keep], cnt[keep]
            t2 = time.perf_counter(); T['lk_back'] = t2 - t1
            # 3. F-RANSAC rejection
            if len(cur_pts) >= 8:
                if self.undistort_f:
                    a = cv2.undistortPoints(prev_pts, K, D, P=K)
                    b = cv2.undistortPoints(cur_pts, K, D, P=K)
                else:
                    a, b = prev_pts, cur_pts
                _, fst = cv2.findFundamentalMat(a, b, cv2.FM_RANSAC, F_THRESH, 0.99)
                if fst is not None:
                    k = fst.ravel() == 1
                    prev_pts, cur_pts, ids, cnt = prev_pts[k], cur_pts[k], ids[k], cnt[k]
            t3 = time.perf_counter(); T['fransac'] = t3 - t2
        else:
            t3 = t0
            T['lk_fwd'] = T['lk_back'] = T['fransac'] = 0.0
        n_tracked = len(cur_pts)
        cnt = cnt + 1
        # 4. mask
        mask = np.full((h, w), 255, np.uint8)
        order = np.argsort(-cnt, kind='stable')
        kept = []
        for i in order:
            x, y = cur_pts[i, 0]
            xi, yi = int(round(x)), int(round(y))  # cv::Point2f -> cv::Point uses cvRound
            if mask[yi, xi] == 255:
                kept.append(i)
                cv2.circle(mask, (xi, yi), MIN_DIST, 0, -1)
        kept = np.array(kept, np.int64)
        cur_pts, ids, cnt = cur_pts[kept], ids[kept], cnt[kept]
        t4 = time.perf_counter(); T['mask'] = t4 - t3
        # 5. GFTT top-up
        n_new = MAX_CNT - len(cur_pts)
        if n_new > 0:
            new = cv2.goodFeaturesToTrack(left, n_new, 0.01, MIN_DIST, mask=mask)
            if new is not None and len(new):
                new = new.astype(np.float32).reshape(-1, 1, 2)
                cur_pts = np.concatenate([cur_pts.reshape(-1, 1, 2), new])
                ids = np.concatenate([ids, np.arange(self.next_id, self.next_id + len(new))])
                self.next_id += len(new)
                cnt = np.concatenate([cnt, np.ones(len(new), np.int64)])
        t5 = time.perf_counter(); T['gftt'] = t5 - t4
        n_feat = len(cur_pts)
        # 6/7. stereo
        n_stereo = 0
        right_pts = None
        if n_feat > 0:
            rp, st, _ = cv2.calcOpticalFlowPyrLK(left, right, cur_pts, None,
                                                 winSize=WIN, maxLevel=3, criteria=CRIT)
            t6 = time.perf_counter(); T['stereo_fwd'] = t6 - t5
            bl, bst, _ = cv2.calcOpticalFlowPyrLK(right, left, rp, None,
                                                  winSize=WIN, maxLevel=3, criteria=CRIT)
            d = np.linalg.norm((cur_pts - bl).reshape(-1, 2), axis=1)
            sk = (st.ravel() == 1) & (bst.ravel() == 1) & in_border(rp.reshape(-1, 2), w, h) & \
                (d <= FB_THRESH)
            right_pts = rp[sk]
            n_stereo = int(sk.sum())
            t7 = time.perf_counter(); T['stereo_back'] = t7 - t6
        else:
            t7 = t5
            T['stereo_fwd'] = T['stereo_back'] = 0.0
        T['total'] = t7 - t0
        if self.undist_stage:
            cv2.undistortPoints(cur_pts, K, D)
            if right_pts is not None and len(right_pts):
                cv2.undistortPoints(right_pts, K, D)
            t8 = time.perf_counter(); T['undist'] = t8 - t7
            T['total+undist'] = t8 - t0
        self.prev_img = left
        self.prev_pts = cur_pts.reshape(-1, 1, 2).astype(np.float32)
        self.ids, self.track_cnt = ids, cnt
        info = dict(n_lk_in=n_lk_in, n_tracked=n_tracked, n_feat=n_feat, n_stereo=n_stereo,
                    n_ge10=int((cnt >= 10).sum()))
        return T, info


def load(root):
    rows = []
    with open(os.path.join(root, 'mav0/cam0/data.csv')) as f:
        for r in csv.reader(f):
            if not r or r[0].startswith('#'):
                continue
            rows.append((int(r[0]), r[1].strip()))
    frames = []
    for t, fn in rows:
        l = cv2.imread(os.path.join(root, 'mav0/cam0/data', fn), cv2.IMREAD_GRAYSCALE)
        r = cv2.imread(os.path.join(root, 'mav0/cam1/data', fn), cv2.IMREAD_GRAYSCALE)
        assert l is not None and r is not None, fn
        frames.append((t, l, r))
    return frames


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('root')
    ap.add_argument('--t-start', type=float, default=11.5)
    ap.add_argument('--t-end', type=float, default=13.0)
    ap.add_argument('--repeats', type=int, default=1, help='re-run whole sequence N times, pool timed frames')
    ap.add_argument('--undistort-f', action='store_true', help='run F-RANSAC on undistorted pixels (like VINS)')
    ap.add_argument('--undist-stage', action='store_true', help='also time undistortPoints of output features')
    ap.add_argument('--verbose', action='store_true')
    a = ap.parse_args()
    print(f'OpenCV {cv2.__version__}, numpy {np.__version__}, cv2 threads={cv2.getNumThreads()}, '
          f'undistort_f={a.undistort_f}')
    frames = load(a.root)
    print(f'{len(frames)} frames, {frames[0][1].shape[1]}x{frames[0][1].shape[0]}')
    pooled = {}
    infos = []
    for rep in range(a.repeats):
        tr = Tracker(a.undistort_f, a.undist_stage)
        rep_T = {}
        for t_ns, l, r in frames:
            T, info = tr.track(l, r)
            ts = t_ns * 1e-9
            if a.t_start - 1e-6 <= ts <= a.t_end + 1e-6:
                for k, v in T.items():
                    pooled.setdefault(k, []).append(v * 1e3)
                    rep_T.setdefault(k, []).append(v * 1e3)
                if rep == 0:
                    infos.append(info)
                if a.verbose and rep == 0:
                    print(f't={ts:.2f} ' + ' '.join(f'{k}={v*1e3:.2f}' for k, v in T.items()) + f' {info}')
        print(f'run {rep}: {len(rep_T["total"])} frames timed, median total {statistics.median(rep_T["total"]):.3f} ms')
    n = len(pooled['total'])
    print(f'\nTimed stereo pairs: {n} ({len(infos)} per run x {a.repeats} runs), t in [{a.t_start}, {a.t_end}] s')
    print(f'{"stage":<14}{"median ms":>10}{"mean ms":>10}{"min ms":>10}{"max ms":>10}')
    for k, v in pooled.items():
        print(f'{k:<14}{statistics.median(v):>10.3f}{statistics.mean(v):>10.3f}{min(v):>10.3f}{max(v):>10.3f}')
    stage_keys = [k for k in pooled if not k.startswith('total') and k != 'undist']
    print(f'sum of stage medians: {sum(statistics.median(pooled[k]) for k in stage_keys):.3f} ms')
    for key in ['n_lk_in', 'n_tracked', 'n_feat', 'n_stereo', 'n_ge10']:
        v = [i[key] for i in infos]
        print(f'{key:<10} median {statistics.median(v):7.1f} min {min(v):4d} max {max(v):4d}')


if __name__ == '__main__':
    main()
