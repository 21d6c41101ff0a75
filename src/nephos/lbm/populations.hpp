#pragma once
// The populations of one lattice-Boltzmann component (q directions x cells, direction-major:
// population i of cell n at [i * Grid3::direction_stride() + n]) in FP32 or, optionally, FP16
// storage.
//
// FP16 storage keeps the arithmetic in FP32 and only stores halves: 2 instead of 4 bytes per
// moving population, so a streaming step moves about half the bytes. The stored values are the
// populations shifted by their rest values (d3q19::equilibrium_shifted), times fp16_scale =
// 2^10: shifted populations are small (|f_i - w_i rho_ref| ~ 1e-4 .. 1e-1) and the scale keeps
// them out of FP16's subnormal range (below 6.1e-5) while leaving room up to |f_i - w_i
// rho_ref| < 64. A power of two, so scaling itself never rounds. The rest population (direction
// 0, which never moves) stays FP32 (rest()): the collision adds to it what rounding the moving
// ones lost, so every cell keeps its mass to FP32 rounding (conservative rounding). See
// docs/lbm.md for the error this costs.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "nephos/core/error.hpp"
#include "nephos/core/huge_page_allocator.hpp"
#include "nephos/lbm/half.hpp"

namespace nephos::lbm {

enum class Storage { fp32, fp16 };

inline Storage parse_storage(const std::string& text) {
  if (text == "fp32") return Storage::fp32;
  if (text == "fp16") return Storage::fp16;
  throw ValueError("population storage must be 'fp32' or 'fp16', got '" + text + "'", {.key = "storage"});
}
inline const char* to_string(Storage s) { return s == Storage::fp32 ? "fp32" : "fp16"; }

inline constexpr float fp16_scale = 1024.0f;  ///< stored half = (f_i - w_i rho_ref) * fp16_scale

class Populations {
 public:
  Populations() = default;
  /// q directions of `stride` values each (population i of cell n at i * stride + n).
  Populations(Storage storage, int q, std::size_t stride) : storage_(storage), stride_(stride) {
    const std::size_t size = static_cast<std::size_t>(q) * stride;
    if (storage == Storage::fp32) {
      f32_.assign(size, 0.0f);
    } else {
      f16_.assign(size, 0);  // direction 0's halves unused: flat indices stay those of FP32
      rest_.assign(stride, 0.0f);
    }
  }
  Storage storage() const { return storage_; }
  std::size_t size() const { return storage_ == Storage::fp32 ? f32_.size() : f16_.size(); }

  float get(std::size_t k) const {
    if (storage_ == Storage::fp32) return f32_[k];
    return k < stride_ ? rest_[k] : half_to_float(f16_[k]) * (1.0f / fp16_scale);
  }
  void set(std::size_t k, float v) {
    if (storage_ == Storage::fp32)
      f32_[k] = v;
    else if (k < stride_)
      rest_[k] = v;
    else
      f16_[k] = float_to_half(v * fp16_scale);
  }
  /// out[j] = get(k + j) for j < n; the range lies within one direction.
  void read(std::size_t k, std::size_t n, float* out) const {
    if (storage_ == Storage::fp32)
      std::copy_n(f32_.data() + k, n, out);
    else if (k < stride_)
      std::copy_n(rest_.data() + k, n, out);
    else
      halves_to_floats(f16_.data() + k, out, static_cast<int>(n), 1.0f / fp16_scale);
  }
  /// set(k + j, in[j]) for j < n; the range lies within one direction.
  void write(std::size_t k, std::size_t n, const float* in) {
    if (storage_ == Storage::fp32)
      std::copy_n(in, n, f32_.data() + k);
    else if (k < stride_)
      std::copy_n(in, n, rest_.data() + k);
    else
      floats_to_halves(f16_.data() + k, in, static_cast<int>(n), fp16_scale);
  }

  /// The stored values as T: float (FP32 storage) or std::uint16_t (FP16 bits of directions
  /// 1 .. q - 1; direction 0 is rest()).
  template <class T>
  T* data() {
    if constexpr (std::is_same_v<T, float>)
      return f32_.data();
    else
      return f16_.data();
  }
  template <class T>
  const T* data() const {
    if constexpr (std::is_same_v<T, float>)
      return f32_.data();
    else
      return f16_.data();
  }
  /// Direction 0, the rest population, as FP32 in either storage (`stride` values).
  float* rest() { return storage_ == Storage::fp32 ? f32_.data() : rest_.data(); }
  const float* rest() const { return storage_ == Storage::fp32 ? f32_.data() : rest_.data(); }

  void swap(Populations& other) noexcept {
    std::swap(storage_, other.storage_);
    std::swap(stride_, other.stride_);
    f32_.swap(other.f32_);
    f16_.swap(other.f16_);
    rest_.swap(other.rest_);
  }

 private:
  Storage storage_ = Storage::fp32;
  std::size_t stride_ = 0;
  // Huge pages: 2 MiB-aligned rows for streaming stores, and fewer TLB misses over the
  // kernels' 38 concurrent streams.
  std::vector<float, HugePageAllocator<float>> f32_;
  std::vector<std::uint16_t, HugePageAllocator<std::uint16_t>> f16_;
  std::vector<float, HugePageAllocator<float>> rest_;  // FP16 storage: direction 0 in FP32
};

}  // namespace nephos::lbm
