#pragma once
// Borrowed views of the engine's motion tensors: [frames][joints][C] floats, row-major.
// C = 4 for rotations (w, x, y, z), C = 3 for translations.
#include <cstddef>

namespace mocap {

template <class T, int C>
struct TensorView {
  T* data = nullptr;
  int frames = 0;
  int joints = 0;

  static constexpr int channels = C;
  std::size_t size() const { return std::size_t(frames) * std::size_t(joints) * C; }
  T* at(int frame, int joint) const {
    return data + (std::size_t(frame) * std::size_t(joints) + std::size_t(joint)) * C;
  }
  bool empty() const { return data == nullptr || frames == 0 || joints == 0; }
  template <class U, int D>
  bool same_shape(const TensorView<U, D>& other) const {  // same frames and joints
    return frames == other.frames && joints == other.joints;
  }
};

using RotationView = TensorView<const float, 4>;  // read-only [F][J][4], wxyz
using RotationSpan = TensorView<float, 4>;        // written [F][J][4]
using TranslationView = TensorView<const float, 3>;
using TranslationSpan = TensorView<float, 3>;

template <class T, int C>
TensorView<const T, C> as_const(TensorView<T, C> v) {
  return {v.data, v.frames, v.joints};
}

}  // namespace mocap
