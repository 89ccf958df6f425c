#include "motion/foot_geometry.h"

namespace ragdoll::motion {

std::vector<character::Vec3> FootCorners(const mjModel* m, int body) {
  std::vector<character::Vec3> corners;
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_bodyid[g] != body || m->geom_type[g] != mjGEOM_BOX) continue;
    double mat[9];
    mju_quat2Mat(mat, m->geom_quat + 4 * g);
    const double* size = m->geom_size + 3 * g;
    for (int c = 0; c < 8; ++c) {
      const double local[3] = {(c & 1 ? 1 : -1) * size[0], (c & 2 ? 1 : -1) * size[1],
                               (c & 4 ? 1 : -1) * size[2]};
      character::Vec3 corner;
      for (int i = 0; i < 3; ++i) {
        corner[i] = m->geom_pos[3 * g + i] + mat[3 * i] * local[0] + mat[3 * i + 1] * local[1] +
                    mat[3 * i + 2] * local[2];
      }
      corners.push_back(corner);
    }
  }
  return corners;
}

}  // namespace ragdoll::motion
