"""A small demonstration of the native core on the seed's worked examples (radians inside,
degrees printed; quaternions are (w, x, y, z); Euler 'XYZ' means R = Rz·Ry·Rx, as in Blender)."""

import numpy as np

import quatcurve as qc

np.set_printoptions(precision=4, suppress=True)
deg = np.radians

print("quatcurve", qc.__version__)

# 1. Rotating the point (0, 1, 1) by 90° about y.
q = qc.axis_angle_to_quat([0, 1, 0], deg(90))
print("\n1. (0, 1, 1) rotated 90° about y:")
print("   q = (w, x, y, z) =", q)
print("   q·[0,P]·q⁻¹      =", qc.quat_rotate_sandwich(q, [0, 1, 1]), "  (expected (1, 1, 0))")

# 2. Gimbal lock: in 'XYZ' at Y = −90°, a turn about X is the same as a turn about Z.
eps = deg(5)
a, b = qc.euler_to_quat([eps, deg(-90), 0]), qc.euler_to_quat([0, deg(-90), eps])
print("\n2. Gimbal lock, Euler 'XYZ' (5°, −90°, 0) vs (0, −90°, 5°):")
print("   angle between the two orientations: %.2e°" % np.degrees(qc.angle_between(a, b)))

# 3. The fixed-angle example: Euler 'XYZ' keys (0, 90°, 0) and (90°, 45°, 90°).
k1, k2 = qc.euler_to_quat(deg([0, 90, 0])), qc.euler_to_quat(deg([90, 45, 90]))
slerp_mid = qc.quat_multiply(qc.quat_pow(qc.quat_multiply(k2, qc.quat_conjugate(k1)), 0.5), k1)
naive_mid = deg([45, 67.5, 45])  # what linear Euler interpolation gives halfway
print("\n3. Halfway between Euler 'XYZ' (0, 90°, 0) and (90°, 45°, 90°):")
print("   the keys are %.1f° apart" % np.degrees(qc.angle_between(k1, k2)))
print("   slerp midpoint in Euler:   ", np.degrees(qc.quat_to_euler(slerp_mid)),
      "  %.1f° and %.1f° from the keys" % tuple(np.degrees(qc.angle_between(slerp_mid, [k1, k2]))))
print("   average of the angles:     ", np.degrees(naive_mid),
      "  %.2f° off the slerp midpoint" % np.degrees(qc.angle_between(slerp_mid, qc.euler_to_quat(naive_mid))))
