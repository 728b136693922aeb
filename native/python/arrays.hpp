// numpy edge of the bindings: turn any array-like into a C-contiguous float64 array with a known
// trailing shape and arbitrary leading (batch) dimensions, and allocate outputs of the same batch
// shape. Shape errors raise ValueError naming the argument.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstddef>
#include <initializer_list>
#include <string>
#include <vector>

namespace quatcurve::bindings {

namespace py = pybind11;
using DArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

struct Batch {
    DArray array;
    std::vector<py::ssize_t> batch_shape;  // leading dimensions
    std::size_t count = 0;                 // product of batch_shape
    const double* data() const { return array.data(); }
};

inline std::string shape_string(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
    return s + (a.ndim() == 1 ? ",)" : ")");
}

// `tail` is the required trailing shape, e.g. {4} for quaternions, {3, 3} for matrices, {} for scalars.
inline Batch as_batch(py::handle obj, std::initializer_list<py::ssize_t> tail, const char* name) {
    DArray arr;
    try {
        arr = DArray::ensure(obj);
    } catch (const py::error_already_set&) {
        arr = DArray();
    }
    if (!arr) throw py::value_error(std::string(name) + ": expected an array of numbers");
    const py::ssize_t nt = static_cast<py::ssize_t>(tail.size());
    bool ok = arr.ndim() >= nt;
    py::ssize_t i = arr.ndim() - nt;
    for (py::ssize_t t : tail) ok = ok && arr.shape(i++) == t;
    if (!ok) {
        std::string want = "(...";
        for (py::ssize_t t : tail) want += ", " + std::to_string(t);
        throw py::value_error(std::string(name) + ": expected shape " + want + "), got " +
                              shape_string(arr));
    }
    Batch b;
    b.count = 1;
    for (py::ssize_t d = 0; d < arr.ndim() - nt; ++d) {
        b.batch_shape.push_back(arr.shape(d));
        b.count *= static_cast<std::size_t>(arr.shape(d));
    }
    b.array = std::move(arr);
    return b;
}

inline DArray make_output(const std::vector<py::ssize_t>& batch_shape,
                          std::initializer_list<py::ssize_t> tail) {
    std::vector<py::ssize_t> shape = batch_shape;
    shape.insert(shape.end(), tail.begin(), tail.end());
    return DArray(shape);
}

// Element name for messages: "q[3]" for the flat batch index 3 ("q" for a single value).
inline std::string element_name(const char* name, const Batch& b, std::size_t flat) {
    if (b.batch_shape.empty()) return name;
    std::string s = std::string(name) + "[";
    std::vector<py::ssize_t> idx(b.batch_shape.size());
    for (std::size_t d = b.batch_shape.size(); d-- > 0;) {
        idx[d] = static_cast<py::ssize_t>(flat % static_cast<std::size_t>(b.batch_shape[d]));
        flat /= static_cast<std::size_t>(b.batch_shape[d]);
    }
    for (std::size_t d = 0; d < idx.size(); ++d) s += (d ? ", " : "") + std::to_string(idx[d]);
    return s + "]";
}

}  // namespace quatcurve::bindings
