// numpy arguments of turtlebot_recon._native: the array types the bindings take and the shape
// checks they share. Only the binding files (src/native/*.cpp) include this; the algorithms'
// headers in include/turtlebot_recon/ know nothing of pybind11.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace turtlebot_recon::bindings {

// Inputs are read in place when they are already C-contiguous of the right dtype; any other
// array (or list) is converted once on the way in.
constexpr auto kInFlags = pybind11::array::c_style | pybind11::array::forcecast;
using U8Grid = pybind11::array_t<std::uint8_t, kInFlags>;
using I8Grid = pybind11::array_t<std::int8_t, kInFlags>;
using I32Array = pybind11::array_t<std::int32_t, kInFlags>;

struct Shape {
  int rows, cols;
};

// Throws std::invalid_argument ("fn: what"), which pybind11 raises as ValueError.
[[noreturn]] inline void fail(const char* fn, const std::string& what) {
  throw std::invalid_argument(std::string(fn) + ": " + what);
}

// The (rows, cols) of a grid argument; ValueError unless it is 2-D.
template <class T>
Shape grid_shape(const pybind11::array_t<T, kInFlags>& a, const char* fn, const char* name) {
  if (a.ndim() != 2)
    fail(fn, std::string(name) + " must be a 2-D (rows, cols) array, got " +
                 std::to_string(a.ndim()) + "-D");
  return {static_cast<int>(a.shape(0)), static_cast<int>(a.shape(1))};
}

// The number n of (row, col) pairs of an (n, 2) cell argument; an empty one may also come as
// shape (0,). ValueError for any other shape.
inline std::size_t cell_count(const I32Array& cells, const char* fn, const char* name) {
  if (!(cells.size() == 0 || (cells.ndim() == 2 && cells.shape(1) == 2)))
    fail(fn, std::string(name) + " must be an (n, 2) array of (row, col)");
  return static_cast<std::size_t>(cells.size() / 2);
}

}  // namespace turtlebot_recon::bindings
