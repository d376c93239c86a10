#!/usr/bin/env python3
"""A second tracker's lower lip for checking lipmap's flags (a measurement aid, not part of
lipmap and never a dependency of it; docs/flags.md says how it was used).

Runs MediaPipe's face mesh with refined lips (mediapipe 0.10.14, the legacy
`mp.solutions.face_mesh.FaceMesh(refine_landmarks=True)`, each frame on its own) on every
frame of FRAMES, enlarged K times (bicubic: the detector misses carphone's 176x144 face at its
own size), and writes the mesh's lower lip at the iBUG points it corresponds to:

  outer lower lip 56-60 on the mesh's outer lower ring 61-146-91-181-84-17-314-405-321-375-291,
  inner lower lip 66-68 on its inner lower ring 78-95-88-178-87-14-317-402-318-324-308,

each at the arc-length fraction of its ring (0 at the subject's right mouth corner) where
the tracker's own point of that number lies, the median over the first half of the frames
(the two trackers space their points along the lip differently; only that convention is
taken from the tracker, on frames apart from the second half the flags are scored on).

Coordinates are the original frame's pixels with pixel centres at integers (lipmap's
convention): MediaPipe's normalised x is x*W - 0.5 (a resize with half-pixel centres keeps
that mapping at any K). The tracker's .pts files are read as dlib's positions, the file's
values - 1/3 (docs/tracking.md: carphone's files hold dlib's points on a 3x enlargement
divided by 3, without the .pts 1-based shift).

usage: mediapipe_lower_lip.py FRAMES PTS OUT.csv [K]
"""
import glob
import os
import sys

import mediapipe as mp
import numpy as np
from PIL import Image

OUTER_RING = [61, 146, 91, 181, 84, 17, 314, 405, 321, 375, 291]
INNER_RING = [78, 95, 88, 178, 87, 14, 317, 402, 318, 324, 308]
# iBUG numbers (1-68) and the ring each lies on.
POINTS = [(56, OUTER_RING), (57, OUTER_RING), (58, OUTER_RING), (59, OUTER_RING),
          (60, OUTER_RING), (66, INNER_RING), (67, INNER_RING), (68, INNER_RING)]


def arc_fractions(ring):
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(ring, axis=0), axis=1))]
    return s / s[-1]


def fraction_of(p, ring):
    """Arc-length fraction of the point of polyline `ring` nearest to `p`."""
    s = arc_fractions(ring)
    best = (np.inf, 0.0)
    for k in range(len(ring) - 1):
        a, b = ring[k], ring[k + 1]
        t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
        d = np.linalg.norm(p - (a + t * (b - a)))
        if d < best[0]:
            best = (d, s[k] + t * (s[k + 1] - s[k]))
    return best[1]


def at_fraction(ring, f):
    s = arc_fractions(ring)
    return np.array([np.interp(f, s, ring[:, 0]), np.interp(f, s, ring[:, 1])])


def read_pts(path):
    body = open(path).read().split("{")[1].split("}")[0].split()
    return np.array(body, float).reshape(-1, 2) - 1.0 / 3.0


def main():
    frames_dir, pts_dir, out = sys.argv[1:4]
    k = int(sys.argv[4]) if len(sys.argv) > 4 else 4
    frames = sorted(glob.glob(os.path.join(frames_dir, "frame_*.png")))
    mesh = []
    with mp.solutions.face_mesh.FaceMesh(static_image_mode=True, max_num_faces=1,
                                         refine_landmarks=True,
                                         min_detection_confidence=0.5) as fm:
        for f in frames:
            im = Image.open(f).convert("RGB")
            w, h = im.size
            found = fm.process(np.asarray(im.resize((w * k, h * k), Image.BICUBIC)))
            if not found.multi_face_landmarks:
                mesh.append(None)
                continue
            lm = found.multi_face_landmarks[0].landmark
            mesh.append(np.array([(p.x * w - 0.5, p.y * h - 0.5) for p in lm]))
    tracker = [read_pts(os.path.join(pts_dir, os.path.basename(f)[:-4] + ".pts"))
               for f in frames]
    first_half = [i for i in range(len(frames) // 2) if mesh[i] is not None]
    fractions = {n: float(np.median([fraction_of(tracker[i][n - 1], mesh[i][ring])
                                     for i in first_half]))
                 for n, ring in POINTS}
    with open(out, "w") as o:
        o.write("# MediaPipe 0.10.14 face mesh (refine_landmarks=True, static images, frames "
                f"enlarged {k}x bicubic): lower lip at iBUG points 56-60, 66-68\n")
        o.write("# written by scripts/mediapipe_lower_lip.py; pixels of the original frame, "
                "pixel centres at integers\n")
        o.write("# arc fractions of the mesh's lip rings (from frames 0-"
                f"{len(frames) // 2 - 1}): "
                + " ".join(f"{n}:{fractions[n]:.3f}" for n, _ in POINTS) + "\n")
        o.write("frame,point,x,y\n")
        for i, m in enumerate(mesh):
            if m is None:
                continue
            for n, ring in POINTS:
                x, y = at_fraction(m[ring], fractions[n])
                o.write(f"{i},{n},{x:.3f},{y:.3f}\n")
    found = sum(m is not None for m in mesh)
    print(f"{out}: face found on {found} of {len(frames)} frames")


if __name__ == "__main__":
    main()
