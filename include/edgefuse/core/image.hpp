// Non-owning views of images in caller-provided (static) buffers.
#pragma once

#include <cstddef>
#include <cstdint>

namespace edgefuse {

//! A width x height grid of T, row-major, `stride` elements between rows.
template <class T>
struct ImageView {
  T* data = nullptr;
  int width = 0;
  int height = 0;
  int stride = 0;  //!< elements per row (>= width)

  ImageView() = default;
  //! \param d first pixel  \param w width in pixels  \param h height in pixels  \param s row stride (0: = w)
  ImageView(T* d, int w, int h, int s = 0) : data(d), width(w), height(h), stride(s ? s : w) {}
  //! A read-only view of a writable one.
  template <class U>
  ImageView(const ImageView<U>& o) : data(o.data), width(o.width), height(o.height), stride(o.stride) {}

  bool empty() const { return data == nullptr || width <= 0 || height <= 0; }
  std::size_t pixel_count() const { return std::size_t(width) * std::size_t(height); }
  T& at(int u, int v) const { return data[std::ptrdiff_t(v) * stride + u]; }
  T* row(int v) const { return data + std::ptrdiff_t(v) * stride; }
  bool contains(int u, int v) const { return u >= 0 && v >= 0 && u < width && v < height; }
};

struct Rgb8 {
  uint8_t r = 0, g = 0, b = 0;
};

//! Colour with a validity flag: a = 255 seen in colour, a = 0 never seen (not painted white).
struct Rgba8 {
  uint8_t r = 0, g = 0, b = 0, a = 0;
};

}  // namespace edgefuse
