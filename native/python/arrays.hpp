// numpy edge of the bindings: turn any array-like into a C-contiguous float64 array with a known
// trailing shape and arbitrary leading (batch) dimensions, and allocate outputs of the same batch
// shape. Shape errors raise ValueError naming the argument.
#pragma once

#include <pybind11/complex.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <complex>
#include <cstddef>
#include <initializer_list>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace quatcurve::bindings {

namespace py = pybind11;
template <class T>
using ArrayOf = py::array_t<T, py::array::c_style | py::array::forcecast>;
using DArray = ArrayOf<double>;
using CArray = ArrayOf<std::complex<double>>;

// An array of T (double, or complex for the 2×2 complex matrix representation) with its batch shape.
template <class T>
struct BatchOf {
    ArrayOf<T> array;
    std::vector<py::ssize_t> batch_shape;  // leading dimensions
    std::size_t count = 0;                 // product of batch_shape
    const T* data() const { return array.data(); }
};
using Batch = BatchOf<double>;
using ComplexBatch = BatchOf<std::complex<double>>;

inline std::string shape_string(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
    return s + (a.ndim() == 1 ? ",)" : ")");
}

// `tail` is the required trailing shape, e.g. {4} for quaternions, {3, 3} for matrices, {} for scalars.
template <class T>
BatchOf<T> as_batch_of(py::handle obj, std::initializer_list<py::ssize_t> tail, const char* name) {
    ArrayOf<T> arr;
    try {
        arr = ArrayOf<T>::ensure(obj);
    } catch (const py::error_already_set&) {
        arr = ArrayOf<T>();
    }
    if (!arr)
        throw py::value_error(std::string(name) + (std::is_same_v<T, double> ? ": expected an array of numbers"
                                                                              : ": expected an array of (complex) numbers"));
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
    BatchOf<T> b;
    b.count = 1;
    for (py::ssize_t d = 0; d < arr.ndim() - nt; ++d) {
        b.batch_shape.push_back(arr.shape(d));
        b.count *= static_cast<std::size_t>(arr.shape(d));
    }
    b.array = std::move(arr);
    return b;
}

inline Batch as_batch(py::handle obj, std::initializer_list<py::ssize_t> tail, const char* name) {
    return as_batch_of<double>(obj, tail, name);
}
inline ComplexBatch as_complex_batch(py::handle obj, std::initializer_list<py::ssize_t> tail, const char* name) {
    return as_batch_of<std::complex<double>>(obj, tail, name);
}

template <class T = double>
ArrayOf<T> make_output(const std::vector<py::ssize_t>& batch_shape, std::initializer_list<py::ssize_t> tail) {
    std::vector<py::ssize_t> shape = batch_shape;
    shape.insert(shape.end(), tail.begin(), tail.end());
    return ArrayOf<T>(shape);
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

// ---- additions for bind_core: broadcasting several inputs, complex arrays ----------------------

// numpy broadcasting of the batch shapes of several inputs (their trailing element shapes are not
// part of it): a single value broadcasts against any batch, (N, 1) against (1, M), and so on.
// index(k, flat) is the flat batch index into input k for the output's flat batch index `flat`.
struct Broadcast {
    std::vector<py::ssize_t> shape;  // output batch shape
    std::size_t count = 1;           // product of shape

    std::size_t index(std::size_t input, std::size_t flat) const {
        const Input& in = inputs_[input];
        if (in.same) return flat;
        if (in.count == 1) return 0;
        std::size_t result = 0;
        for (std::size_t d = shape.size(); d-- > 0;) {
            const std::size_t n = static_cast<std::size_t>(shape[d]);
            result += (flat % n) * in.strides[d];
            flat /= n;
        }
        return result;
    }

    struct Input {
        bool same = false;                  // batch shape equals the output's
        std::size_t count = 1;              // number of elements in the input batch
        std::vector<std::size_t> strides;   // per output dimension, 0 where broadcast
    };
    std::vector<Input> inputs_;
};

inline std::string batch_shape_string(const std::vector<py::ssize_t>& shape) {
    std::string s = "(";
    for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
    return s + (shape.size() == 1 ? ",)" : ")");
}

// Broadcast the batch shapes of `batches` (named by `names`, for the error message:
// "a, b: batch shapes (3,) and (4,) do not broadcast").
inline Broadcast broadcast(std::initializer_list<std::pair<const char*, const std::vector<py::ssize_t>*>> batches) {
    Broadcast bc;
    std::size_t ndim = 0;
    for (const auto& b : batches) ndim = std::max(ndim, b.second->size());
    bc.shape.assign(ndim, 1);
    auto fail = [&batches]() {
        std::string names, shapes;
        for (const auto& b : batches) {
            names += (names.empty() ? "" : ", ") + std::string(b.first);
            shapes += (shapes.empty() ? "" : " and ") + batch_shape_string(*b.second);
        }
        throw py::value_error(names + ": batch shapes " + shapes + " do not broadcast");
    };
    for (const auto& b : batches) {
        const std::size_t off = ndim - b.second->size();
        for (std::size_t d = 0; d < b.second->size(); ++d) {
            const py::ssize_t n = (*b.second)[d];
            if (n == bc.shape[off + d] || n == 1) continue;
            if (bc.shape[off + d] != 1) fail();
            bc.shape[off + d] = n;
        }
    }
    for (py::ssize_t n : bc.shape) bc.count *= static_cast<std::size_t>(n);
    for (const auto& b : batches) {
        Broadcast::Input in;
        const std::size_t off = ndim - b.second->size();
        in.same = b.second->size() == ndim && *b.second == bc.shape;
        in.strides.assign(ndim, 0);
        std::size_t stride = 1;
        for (std::size_t d = b.second->size(); d-- > 0;) {
            const std::size_t n = static_cast<std::size_t>((*b.second)[d]);
            in.strides[off + d] = n == 1 ? 0 : stride;
            stride *= n;
        }
        in.count = stride;
        bc.inputs_.push_back(std::move(in));
    }
    return bc;
}

// Element name for messages from a batch shape ("m[2, 1]"; "m" for a single value).
inline std::string element_name(const char* name, const std::vector<py::ssize_t>& batch_shape,
                                std::size_t flat) {
    Batch b;
    b.batch_shape = batch_shape;
    return element_name(name, b, flat);
}

// ---- rows of samples: times (N,), values (N, width), sample indices -----------------------------

using IArray = py::array_t<std::int64_t>;

inline std::vector<double> read_times(py::handle obj) {
    const Batch b = as_batch(obj, {}, "times");
    if (b.batch_shape.size() != 1)
        throw py::value_error("times: expected a 1-D array, got shape " + shape_string(b.array));
    return std::vector<double>(b.data(), b.data() + b.count);
}

// An (N, width) array as N rows; width 4 for quaternions, 3 for Euler angles.
inline Batch read_rows(py::handle obj, py::ssize_t width, const char* name, std::size_t n) {
    Batch b = as_batch(obj, {width}, name);
    if (b.batch_shape.size() != 1)
        throw py::value_error(std::string(name) + ": expected shape (N, " + std::to_string(width) +
                              "), got " + shape_string(b.array));
    if (b.count != n)
        throw py::value_error(std::string(name) + ": " + std::to_string(b.count) +
                              " rows for " + std::to_string(n) + " times");
    return b;
}

inline IArray index_array(const std::vector<std::size_t>& indices) {
    IArray out(static_cast<py::ssize_t>(indices.size()));
    auto* p = out.mutable_data();
    for (std::size_t a = 0; a < indices.size(); ++a) p[a] = static_cast<std::int64_t>(indices[a]);
    return out;
}

// A 1-D array of sample indices (integers ≥ 0); order and range are checked by the native side.
inline std::vector<std::size_t> read_indices(py::handle obj, const char* name) {
    const Batch b = as_batch(obj, {}, name);
    if (b.batch_shape.size() != 1)
        throw py::value_error(std::string(name) + ": expected a 1-D array of sample indices, got shape " +
                              shape_string(b.array));
    std::vector<std::size_t> out(b.count);
    for (std::size_t a = 0; a < b.count; ++a) {
        const double v = b.data()[a];
        if (!(v >= 0.0) || v != std::floor(v) || v > 9.007199254740992e15)
            throw py::value_error(std::string(name) + "[" + std::to_string(a) + "]: not a sample index (" +
                                  std::to_string(v) + ")");
        out[a] = static_cast<std::size_t>(v);
    }
    return out;
}

}  // namespace quatcurve::bindings
