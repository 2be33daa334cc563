// Argument checks shared by the depth filters (private to src/filters).
#pragma once

#include <cstdint>

#include "edgefuse/core/image.hpp"

namespace edgefuse {
namespace filters_detail {

//! A view that can be read or written: non-null, positive size, stride covering a row.
template <class T>
bool usable(const ImageView<T>& v) {
  return !v.empty() && v.stride >= v.width;
}

template <class A, class B>
bool same_size(const ImageView<A>& a, const ImageView<B>& b) {
  return a.width == b.width && a.height == b.height;
}

//! First and one-past-last byte a view touches.
template <class T>
void byte_range(const ImageView<T>& v, uintptr_t& begin, uintptr_t& end) {
  begin = reinterpret_cast<uintptr_t>(v.data);
  end = begin + (uintptr_t(v.height - 1) * uintptr_t(v.stride) + uintptr_t(v.width)) * sizeof(T);
}

//! True when the two views share any memory.
template <class A, class B>
bool overlap(const ImageView<A>& a, const ImageView<B>& b) {
  uintptr_t a0, a1, b0, b1;
  byte_range(a, a0, a1);
  byte_range(b, b0, b1);
  return a0 < b1 && b0 < a1;
}

//! Pixel-wise steps may run in place, but only on exactly the same pixels: a shifted overlap
//! would read pixels the step has already written.
template <class A, class B>
bool in_place_or_disjoint(const ImageView<A>& in, const ImageView<B>& out) {
  const bool same = static_cast<const void*>(in.data) == static_cast<const void*>(out.data) && in.stride == out.stride;
  return same || !overlap(in, out);
}

}  // namespace filters_detail
}  // namespace edgefuse
