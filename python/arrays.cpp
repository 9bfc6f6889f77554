#include "python/arrays.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <string>

namespace mocap::python {
namespace {

std::atomic<std::size_t> copies{0};

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

py::array as_array(py::handle object, const char* what) {
  if (!py::isinstance<py::array>(object) && !py::isinstance<py::sequence>(object))
    throw py::type_error(std::string(what) + " must be a numpy array, got " +
                         std::string(py::str(py::type::of(object).attr("__name__"))));
  py::array a = py::array::ensure(object);
  if (!a) throw py::type_error(std::string(what) + " must be convertible to a numpy array");
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u')
    throw py::type_error(std::string(what) + " must hold real numbers, got dtype " +
                         std::string(py::str(a.dtype())));
  return a;
}

}  // namespace

std::size_t input_copies() {
  return copies.load();
}

void check_shape(const py::array& a, int channels, const char* what) {
  if (a.ndim() != 3 || a.shape(2) != channels)
    throw py::value_error(std::string(what) + " must have shape (F, J, " +
                          std::to_string(channels) + "), got " + shape_text(a));
  if (a.shape(0) > py::ssize_t(1) << 30 || a.shape(1) > py::ssize_t(1) << 30)
    throw py::value_error(std::string(what) + " is too large: " + shape_text(a));
}

void to_scalar_last(float* q, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i, q += 4) std::rotate(q, q + 1, q + 4);
}

void to_scalar_first(float* q, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i, q += 4) std::rotate(q, q + 3, q + 4);
}

void copy_into(py::handle object, int channels, bool scalar_first, const char* what,
               std::vector<float>& out, int& frames, int& joints) {
  py::array a = as_array(object, what);
  check_shape(a, channels, what);
  // forcecast: numpy's own float64 -> float32 rounding (to nearest), and any strides.
  auto f = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!f) throw py::type_error(std::string(what) + " cannot be converted to float32");
  frames = int(a.shape(0));
  joints = int(a.shape(1));
  out.resize(std::size_t(f.size()));
  if (!out.empty()) std::memcpy(out.data(), f.data(), sizeof(float) * out.size());
  if (channels == 4 && !scalar_first) to_scalar_first(out.data(), out.size() / 4);
  ++copies;
}

Borrowed borrow(py::handle object, int channels, bool scalar_first, const char* what) {
  Borrowed b;
  b.array = as_array(object, what);
  check_shape(b.array, channels, what);
  b.is_float64 = b.array.dtype().is(py::dtype::of<double>());
  const bool in_place = b.array.dtype().is(py::dtype::of<float>()) &&
                        (b.array.flags() & py::array::c_style) && (channels != 4 || scalar_first);
  if (in_place) {
    b.data = static_cast<const float*>(b.array.data());
    b.frames = int(b.array.shape(0));
    b.joints = int(b.array.shape(1));
  } else {
    copy_into(b.array, channels, scalar_first, what, b.storage, b.frames, b.joints);
    b.data = b.storage.data();
  }
  return b;
}

// Frames counted from 1, as the engine's messages (io/clip_validation.cpp) and BVH errors count.
std::string check_rotation_values(RotationView rotations) {
  for (int t = 0; t < rotations.frames; ++t)
    for (int j = 0; j < rotations.joints; ++j) {
      const float* q = rotations.at(t, j);
      for (int c = 0; c < 4; ++c)
        if (!std::isfinite(q[c]))
          return fmt::format("{} in rotations at frame {}, joint '{}'",
                             std::isnan(q[c]) ? "NaN" : "infinity", t + 1, j);
      const double norm = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] +
                                    double(q[2]) * q[2] + double(q[3]) * q[3]);
      if (std::abs(norm - 1.0) > 1e-3)
        return fmt::format(
            "rotation at frame {}, joint '{}' is not a unit quaternion (norm {:.6g})", t + 1, j,
            norm);
    }
  return {};
}

py::array adopt(std::vector<float>&& values, int frames, int joints, int channels,
                bool scalar_first, bool as_float64) {
  if (channels == 4 && !scalar_first) to_scalar_last(values.data(), values.size() / 4);
  const std::vector<py::ssize_t> shape{frames, joints, channels};
  if (as_float64) {
    py::array_t<double> wide(shape);
    std::copy(values.begin(), values.end(), wide.mutable_data());
    return wide;
  }
  auto* owned = new std::vector<float>(std::move(values));
  py::capsule owner(owned, [](void* p) { delete static_cast<std::vector<float>*>(p); });
  return py::array_t<float>(shape, owned->data(), owner);
}

}  // namespace mocap::python
