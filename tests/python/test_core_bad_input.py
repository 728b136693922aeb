"""Bad input for every public function of the orientation core: non-finite values, zero-length
quaternions and axes, singular or reflecting matrices, wrong shapes, batches that do not broadcast,
unknown Euler orders. Each raises ValueError whose message names the argument and the element."""

import numpy as np
import pytest

import quatcurve as qc

# Good batches of three elements per kind of argument.
GOOD = {
    "quat": np.array([[1.0, 0, 0, 0], [0.5, 0.5, 0.5, 0.5], [0.0, 0.6, 0.0, 0.8]]),
    "vec": np.array([[1.0, 2, 3], [0, 0, 1], [-1, 0.5, 0]]),
    "scalar": np.array([0.1, -2.0, 3.0]),
    "mat3": np.stack([np.eye(3)] * 3),
    "mat4": np.stack([np.eye(4)] * 3),
    "complex2": np.stack([np.eye(2, dtype=complex)] * 3),
    "real4": np.stack([np.eye(4)] * 3),
}
TAIL = {"quat": (4,), "vec": (3,), "scalar": (), "mat3": (3, 3), "mat4": (4, 4), "complex2": (2, 2), "real4": (4, 4)}

# name -> (arguments as (argument name, kind, may be zero-length?), takes an order?)
#   zero: "quaternion" / "axis" when a zero-length value is refused, "matrix" when a singular one is.
FUNCTIONS = {
    "quat_multiply": ([("a", "quat", None), ("b", "quat", None)], False),
    "quat_conjugate": ([("q", "quat", None)], False),
    "quat_inverse": ([("q", "quat", "quaternion")], False),
    "quat_divide": ([("a", "quat", None), ("b", "quat", "quaternion")], False),
    "quat_norm": ([("q", "quat", None)], False),
    "quat_normalize": ([("q", "quat", "quaternion")], False),
    "quat_exp": ([("q", "quat", None)], False),
    "quat_log": ([("q", "quat", "quaternion")], False),
    "quat_pow": ([("q", "quat", "quaternion"), ("t", "scalar", None)], False),
    "quat_rotate": ([("q", "quat", "quaternion"), ("v", "vec", None)], False),
    "quat_rotate_sandwich": ([("q", "quat", "quaternion"), ("v", "vec", None)], False),
    "axis_angle_to_quat": ([("axis", "vec", "axis"), ("angle", "scalar", None)], False),
    "quat_to_axis_angle": ([("q", "quat", "quaternion")], False),
    "angle_between": ([("a", "quat", "quaternion"), ("b", "quat", "quaternion")], False),
    "quat_to_matrix": ([("q", "quat", "quaternion")], False),
    "matrix_to_quat": ([("m", "mat3", "matrix")], False),
    "nearest_rotation": ([("m", "mat3", "matrix")], False),
    "translation_matrix": ([("t", "vec", None)], False),
    "scale_matrix": ([("s", "vec", None)], False),
    "rotation_matrix4": ([("q", "quat", "quaternion")], False),
    "transform_points": ([("M", "mat4", None), ("P", "vec", None)], False),
    "transform_directions": ([("M", "mat4", None), ("D", "vec", None)], False),
    "quat_to_complex2": ([("q", "quat", None)], False),
    "complex2_to_quat": ([("m", "complex2", None)], False),
    "quat_to_real4": ([("q", "quat", None)], False),
    "real4_to_quat": ([("m", "real4", None)], False),
    "euler_to_quat": ([("angles", "vec", None)], True),
    "euler_to_matrix": ([("angles", "vec", None)], True),
    "quat_to_euler": ([("q", "quat", "quaternion")], True),
    "matrix_to_euler": ([("m", "mat3", "matrix")], True),
    "euler_compat": ([("angles", "vec", None), ("ref", "vec", None)], True),
    "euler_filter": ([("angles", "vec", None)], True),
    "gimbal_distance": ([("angles", "vec", None)], True),
}


def call(name, replace=None, order="XYZ"):
    args, takes_order = FUNCTIONS[name]
    kwargs = {arg: GOOD[kind].copy() for arg, kind, _ in args}
    kwargs.update(replace or {})
    if takes_order:
        kwargs["order"] = order
    return getattr(qc, name)(**kwargs)


def cases(kind_filter):
    return [(name, arg, kind, zero) for name, (args, _) in FUNCTIONS.items() for arg, kind, zero in args
            if kind_filter(kind, zero)]


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
def test_good_input_works(name):
    call(name)


@pytest.mark.parametrize("name,arg,kind,zero", cases(lambda kind, zero: True))
@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_names_the_element(name, arg, kind, zero, value):
    bad = GOOD[kind].copy()
    bad.reshape(len(bad), -1)[2, -1] = value
    with pytest.raises(ValueError) as info:
        call(name, {arg: bad})
    msg = str(info.value)
    assert msg.startswith(f"{arg}[2]: non-finite value"), msg
    assert ("nan" if np.isnan(value) else "inf") in msg


@pytest.mark.parametrize("name,arg,kind,zero", cases(lambda kind, zero: zero in ("quaternion", "axis")))
def test_zero_length_names_the_element(name, arg, kind, zero):
    bad = GOOD[kind].copy()
    bad[1] = 0.0
    with pytest.raises(ValueError, match=rf"^{arg}\[1\]: zero-length {zero}$"):
        call(name, {arg: bad})
    tiny = GOOD[kind].copy()
    tiny[1] = 1e-310  # underflows: as good as zero
    with pytest.raises(ValueError, match=rf"^{arg}\[1\]: zero-length {zero}$"):
        call(name, {arg: tiny})


@pytest.mark.parametrize("name,arg,kind,zero", cases(lambda kind, zero: zero == "matrix"))
def test_singular_and_reflecting_matrices_name_the_element(name, arg, kind, zero):
    bad = GOOD[kind].copy()
    bad[2] = np.diag([1.0, 1.0, 0.0])
    with pytest.raises(ValueError, match=rf"^{arg}\[2\]: singular matrix"):
        call(name, {arg: bad})
    bad[2] = np.diag([1.0, -1.0, 1.0])
    with pytest.raises(ValueError, match=rf"^{arg}\[2\]: reflection \(determinant < 0\)"):
        call(name, {arg: bad})


# (a scalar argument takes any shape: its whole shape is the batch; see test_batches_that_do_not_broadcast)
@pytest.mark.parametrize("name,arg,kind,zero", cases(lambda kind, zero: kind != "scalar"))
def test_wrong_shape_names_the_argument(name, arg, kind, zero):
    wrong = np.zeros((3, 5))
    with pytest.raises(ValueError, match=rf"^{arg}: expected shape \(\.\.\.,"):
        call(name, {arg: wrong})
    with pytest.raises(ValueError, match=rf"^{arg}: expected"):
        call(name, {arg: "not numbers"})


@pytest.mark.parametrize("name", [n for n, (args, _) in FUNCTIONS.items() if len(args) == 2])
def test_batches_that_do_not_broadcast(name):
    (a, kind_a, _), (b, kind_b, _) = FUNCTIONS[name][0]
    long = np.concatenate([GOOD[kind_b]] * 2)[:4]
    with pytest.raises(ValueError, match=rf"^{a}, {b}: batch shapes \(3,\) and \(4,\) do not broadcast$"):
        call(name, {b: long})


@pytest.mark.parametrize("name", [n for n, (_, takes_order) in FUNCTIONS.items() if takes_order] + ["euler_middle_axis"])
@pytest.mark.parametrize("order", ["xyz", "XYX", "", "XYZW"])
def test_unknown_order(name, order):
    with pytest.raises(ValueError, match=rf"^order: unknown Euler order '{order}' \(expected one of XYZ, XZY, YXZ, YZX, ZXY, ZYX\)$"):
        if name == "euler_middle_axis":
            qc.euler_middle_axis(order)
        else:
            call(name, order=order)


def test_element_names_in_multidimensional_batches():
    q = np.ones((2, 3, 4))
    q[1, 2] = 0.0
    with pytest.raises(ValueError, match=r"^q\[1, 2\]: zero-length quaternion$"):
        qc.quat_to_matrix(q)
    # broadcast: the name is the element of the argument itself
    with pytest.raises(ValueError, match=r"^b\[1\]: zero-length quaternion$"):
        qc.quat_divide(np.ones((5, 2, 4)), [[1.0, 0, 0, 0], [0, 0, 0, 0]])
    # a single value has no index
    with pytest.raises(ValueError, match=r"^axis: zero-length axis$"):
        qc.axis_angle_to_quat([0.0, 0, 0], 1.0)


def test_specific_edge_messages():
    with pytest.raises(ValueError, match=r"^m: expected shape \(\.\.\., 3, 3\) or \(\.\.\., 4, 4\), got \(2, 3\)$"):
        qc.matrix_to_quat(np.zeros((2, 3)))
    projective = np.eye(4)
    projective[3] = [1.0, 0, 0, 0]  # w = x
    with pytest.raises(ValueError, match=r"^P\[1\]: .*maps to infinity"):
        qc.transform_points(projective, [[1.0, 0, 0], [0, 1, 0]])
    with pytest.raises(ValueError, match=r"^m\[0\]: non-finite value nan in the imaginary part of entry \[1\]\[0\]$"):
        qc.complex2_to_quat([[[1, 0], [complex(0, np.nan), 1]]])
    with pytest.raises(ValueError, match=r"^compat\[2\]: non-finite"):
        qc.quat_to_euler(GOOD["quat"], "XYZ", compat=np.array([[0.0, 0, 0]] * 2 + [[0, np.inf, 0]]))
    with pytest.raises(ValueError, match=r"^q, compat: batch shapes \(3,\) and \(2,\) do not broadcast$"):
        qc.quat_to_euler(GOOD["quat"], "XYZ", compat=np.zeros((2, 3)))


def test_every_core_function_is_covered():
    for name in list(FUNCTIONS) + ["euler_middle_axis"]:
        assert callable(getattr(qc, name)), name
        assert "radians" in getattr(qc, name).__doc__ or name == "euler_middle_axis"
