// Value types and the (w, x, y, z) convention at every array edge.
//
// GLM stores a quaternion as (x, y, z, w) in memory but its constructor takes (w, x, y, z);
// never reinterpret raw memory, always go through from_wxyz / to_wxyz.
#pragma once

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace quatcurve {

using Quat = glm::dquat;
using Vec3 = glm::dvec3;
using Vec4 = glm::dvec4;
using Mat3 = glm::dmat3;  // column-major, as GLM: m[col][row]
using Mat4 = glm::dmat4;

inline Quat from_wxyz(const double* p) { return Quat(p[0], p[1], p[2], p[3]); }
inline void to_wxyz(const Quat& q, double* p) {
    p[0] = q.w;
    p[1] = q.x;
    p[2] = q.y;
    p[3] = q.z;
}

}  // namespace quatcurve
