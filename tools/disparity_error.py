#!/usr/bin/env python3
"""SGBM's disparity error on one entity's pixels of rendered frames, one pass and with the
half-pixel pass (see docs/TRACKING.md, "Sub-pixel disparity").

    for t in 10 11 12 13 14; do
      build/tools/vigil render scenarios/dis_left_bag.yaml --camera cam_corridor --out /tmp/rf_$t --at $t
    done
    python3 tools/disparity_error.py /tmp/rf_10 /tmp/rf_11 /tmp/rf_12 /tmp/rf_13 /tmp/rf_14

Needs python3-opencv and python3-numpy (apt-get install python3-opencv). Uses OpenCV's SGBM with
vigil's defaults (64 disparities, block 5, P1/P2 as OpenCV advises); the half-pixel pass matches
the left image again against the right one shifted by half a pixel and averages the two where
both are valid and within 1 px, as vision/stereo_matcher.cpp does. Labels come from labels.txt.
"""
import sys

import cv2
import numpy as np


def sgbm(left, right, block=5):
    m = cv2.StereoSGBM_create(0, 64, block, 8 * 3 * block * block, 32 * 3 * block * block, 1, 63, 10, 100, 2,
                              cv2.STEREO_SGBM_MODE_SGBM)
    return m.compute(left, right).astype(np.float32) / 16


def half_pixel(left, right):
    first = sgbm(left, right)
    shift = np.float32([[1, 0, -0.5], [0, 1, 0]])  # right'(x) = right(x + 0.5)
    shifted = cv2.warpAffine(right, shift, (right.shape[1], right.shape[0]), flags=cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REPLICATE)
    second = sgbm(left, shifted) - 0.5
    both = (first > 0) & (second > -0.5 + 1e-6) & (np.abs(first - second) < 1)
    return np.where(both, 0.5 * (first + second), first).astype(np.float32)


def main(folders):
    for folder in folders:
        left = cv2.imread(folder + '/left_000000.png')
        right = cv2.imread(folder + '/right_000000.png')
        truth = cv2.imread(folder + '/disparity_000000.png', cv2.IMREAD_UNCHANGED).astype(np.float32) / 256
        labels = cv2.imread(folder + '/labels_000000.png', cv2.IMREAD_UNCHANGED)
        names = {}
        for line in open(folder + '/labels.txt'):
            if line.startswith('#') or not line.strip():
                continue
            k, name = line.split()
            names[int(k)] = name
        one, two = sgbm(left, right), half_pixel(left, right)
        for k, name in sorted(names.items()):
            m = (labels == k) & (truth > 0) & (one > 0)
            if m.sum() < 50:
                continue
            e1 = np.median(one[m] - truth[m])
            e2 = np.median(two[m] - truth[m])
            print('%s %-8s %5d px  true disparity %5.2f px  median error: one pass %+.3f px, half-pixel pass %+.3f px'
                  % (folder, name, m.sum(), np.median(truth[m]), e1, e2))


if __name__ == '__main__':
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
