// turtlebot_recon._native: the one compiled module. Each area registers its functions here.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <octomap/octomap.h>
#include <ompl/config.h>

#include "numpy_args.hpp"
#include "turtlebot_recon/rectangles.hpp"

namespace py = pybind11;
using namespace turtlebot_recon;

// Areas, one .cpp each (src/native/<area>.cpp).
void register_mapping(py::module_& m);    // occupancy_grid.cpp
void register_planning(py::module_& m);   // planning.cpp
void register_exploration(py::module_& m);  // exploration.cpp
void register_lattice(py::module_& m);    // lattice.cpp
void register_perception(py::module_& m);  // camera_coverage.cpp
void register_slam(py::module_& m);  // scan_matcher.cpp
void register_body_field(py::module_& m);  // body_field.cpp (the controllers' obstacle test)
void register_dwa(py::module_& m);  // dwa.cpp (the dynamic window approach)
void register_ilqr(py::module_& m);  // ilqr.cpp (Tube MPPI's ancillary tracker)
void register_mppi(py::module_& m);  // mppi.cpp (the MPPI controller's optimizer)
void register_sampling(py::module_& m);  // sampling_planner.cpp (OMPL's planners)
void register_rrt_seed003(py::module_& m);  // rrt_seed003.cpp (seed 003's RRT, the baseline)
void register_octomap(py::module_& m);  // octomap_layer.cpp (the 3-D obstacle layer)

namespace {

py::array_t<std::int32_t> py_merge_rectangles(const bindings::U8Grid& mask) {
  const bindings::Shape s = bindings::grid_shape(mask, "merge_rectangles", "mask");
  std::vector<Rect> rects;
  {
    py::gil_scoped_release release;
    rects = merge_rectangles(mask.data(), s.rows, s.cols);
  }
  py::array_t<std::int32_t> out({static_cast<py::ssize_t>(rects.size()), py::ssize_t{4}});
  auto o = out.mutable_unchecked<2>();
  for (size_t i = 0; i < rects.size(); ++i) {
    o(i, 0) = rects[i].row;
    o(i, 1) = rects[i].col;
    o(i, 2) = rects[i].rows;
    o(i, 3) = rects[i].cols;
  }
  return out;
}

py::dict build_info() {
  py::dict d;
  d["eigen"] = std::to_string(EIGEN_WORLD_VERSION) + "." + std::to_string(EIGEN_MAJOR_VERSION) +
               "." + std::to_string(EIGEN_MINOR_VERSION);
  d["octomap"] = octomap::OcTree(0.05).getTreeType();  // links liboctomap
  d["ompl"] = std::to_string(OMPL_MAJOR_VERSION) + "." + std::to_string(OMPL_MINOR_VERSION) + "." +
              std::to_string(OMPL_PATCH_VERSION);
  return d;
}

}  // namespace

PYBIND11_MODULE(_native, m) {
  m.doc() = "turtlebot_recon C++ core (Eigen, OctoMap, OMPL)";
  m.def("merge_rectangles", &py_merge_rectangles, py::arg("mask"),
        "Cover the non-zero cells of a 2-D uint8 mask with disjoint rectangles.\n"
        "Returns an (N, 4) int32 array of (row, col, rows, cols), rows counted from the top.");
  m.def("build_info", &build_info, "Versions of the C++ libraries the module was built against.");
  register_mapping(m);
  register_planning(m);
  register_exploration(m);
  register_lattice(m);
  register_perception(m);
  register_slam(m);
  register_body_field(m);
  register_dwa(m);
  register_ilqr(m);
  register_mppi(m);
  register_sampling(m);
  register_rrt_seed003(m);
  register_octomap(m);
}
