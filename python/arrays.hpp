#pragma once
// numpy arrays to and from the engine's tensors ([F][J][4] wxyz rotations, [F][J][3]
// translations, float32): borrowed without a copy where the layout allows, converted otherwise.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstddef>
#include <string>
#include <vector>

#include "core/tensor.hpp"

namespace mocap::python {

namespace py = pybind11;

// Inputs converted into a private float32 buffer (not borrowed) since the module was loaded; the
// tests read it to prove that a C-contiguous float32 wxyz array is used in place.
std::size_t input_copies();

// The shape (F, J, C) of `array`, or a ValueError naming `what`: "rotations must have shape
// (F, J, 4), got (3, 5)".
void check_shape(const py::array& array, int channels, const char* what);

// A read-only [F][J][C] float32 view of `object`: the array's own memory when it is float32,
// C-contiguous and (for rotations) scalar first; else a converted copy held in `storage`.
struct Borrowed {
  py::array array;             // keeps the numpy memory alive while the view is used
  std::vector<float> storage;  // the converted copy, when one was needed
  const float* data = nullptr;
  int frames = 0, joints = 0;
  bool is_float64 = false;  // the caller's dtype, to answer in the same precision
};
Borrowed borrow(py::handle object, int channels, bool scalar_first, const char* what);
inline RotationView rotation_view(const Borrowed& b) {
  return {b.data, b.frames, b.joints};
}
inline TranslationView translation_view(const Borrowed& b) {
  return {b.data, b.frames, b.joints};
}

// Why `rotations` cannot go into a kernel, in the words of engine::check_clip_values (which needs
// an Clip, that is a copy; joints are named by index as for bare arrays): "NaN in rotations
// at frame 3, joint '1'", "... is not a unit quaternion (norm 2)"; "" when they can.
std::string check_rotation_values(RotationView rotations);

// Copies `object` ([F][J][C], any real dtype and layout) into `out` as float32, scalar first.
void copy_into(py::handle object, int channels, bool scalar_first, const char* what,
               std::vector<float>& out, int& frames, int& joints);

// A float32 array of `shape` that owns `values` (moved, no copy). With rotations given scalar
// last, the quaternions are reordered in place to (x, y, z, w); as_float64 widens (a copy).
py::array adopt(std::vector<float>&& values, int frames, int joints, int channels,
                bool scalar_first = true, bool as_float64 = false);

// (w, x, y, z) <-> (x, y, z, w) in place on `count` quaternions.
void to_scalar_last(float* q, std::size_t count);
void to_scalar_first(float* q, std::size_t count);

}  // namespace mocap::python
