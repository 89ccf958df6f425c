"""A BVH made imperfect the way captures are: its shins (the LeftFoot and RightFoot offsets)
scaled away from the skeleton that performed the motion, and Gaussian jitter on every rotation
channel of every frame.

    bvh_distort.py IN OUT SHIN_SCALE NOISE_DEGREES SEED
"""
import random
import sys

src, dst, shin, noise, seed = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5])
rng = random.Random(seed)
lines = open(src).read().split("\n")
out, joint, channels, in_motion = [], None, [], False
for i, line in enumerate(lines):
    s = line.strip()
    if s.startswith(("ROOT", "JOINT")):
        joint = s.split()[1]
    if s.startswith("CHANNELS"):
        n = int(s.split()[1])
        channels += [c.endswith("rotation") for c in s.split()[2:2 + n]]
    if s.startswith("OFFSET") and joint in ("LeftFoot", "RightFoot") and not in_motion:
        v = [float(x) * shin for x in s.split()[1:]]
        line = line[:line.index("OFFSET")] + "OFFSET " + " ".join("%.6f" % x for x in v)
        joint = None
    if in_motion and s:
        vals = [float(x) for x in s.split()]
        vals = [v + (rng.gauss(0, noise) if rot else 0) for v, rot in zip(vals, channels)]
        line = " ".join("%.6f" % v for v in vals)
    if s.startswith("Frame Time"):
        in_motion = True
    out.append(line)
open(dst, "w").write("\n".join(out))
