# A BVH made "In Place" as Mixamo does it: the root's horizontal position channels (X and Z, the
# file being Y-up) zeroed in every frame, everything else as it was.
#   python3 in_place_copy.py IN.bvh OUT.bvh
import sys

lines = open(sys.argv[1]).read().split("\n")
top = next(i for i, line in enumerate(lines) if line.startswith("Frame Time"))
channels = next(line for line in lines if "CHANNELS" in line).split()[2:]
x, z = channels.index("Xposition"), channels.index("Zposition")
frames = []
for line in lines[top + 1:]:
    if line.strip():
        values = line.split()
        values[x] = values[z] = "0"
        frames.append(" ".join(values))
open(sys.argv[2], "w").write("\n".join(lines[: top + 1] + frames) + "\n")
