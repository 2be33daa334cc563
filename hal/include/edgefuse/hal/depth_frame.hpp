// A depth frame in caller-provided (static) storage. The HAL never allocates a frame: the caller
// points a DepthFrame at buffers it owns (a pool slot, see acquisition/frame_pool.hpp) and a
// camera fills them. Depth is raw uint16 (value / depth_scale = z-depth in metres, 0 = invalid),
// colour is registered to depth (same size), amplitude is a ToF camera's signal strength.
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/core/image.hpp"

namespace edgefuse::hal {

struct DepthFrame {
  // --- storage, set once by the owner ------------------------------------------------------
  uint16_t* depth = nullptr;      //!< capacity_pixels raw depth values
  Rgb8* colour = nullptr;         //!< capacity_pixels colour values, or null (colour not kept)
  uint16_t* amplitude = nullptr;  //!< capacity_pixels amplitude values, or null (not kept)
  int capacity_pixels = 0;        //!< size of each buffer in pixels

  // --- filled by the camera for every frame ------------------------------------------------
  int width = 0;                 //!< pixels per row of this frame
  int height = 0;                //!< rows of this frame
  float depth_scale = 1000;      //!< raw / depth_scale = metres
  bool has_colour = false;       //!< colour[] holds this frame's registered colour
  bool has_amplitude = false;    //!< amplitude[] holds this frame's amplitude
  uint64_t stamp_us = 0;         //!< capture time on the HAL clock (monotonic)
  uint32_t sequence = 0;         //!< device frame counter (gaps = frames lost before us)

  std::size_t pixel_count() const { return std::size_t(width) * std::size_t(height); }
  ImageView<const uint16_t> depth_view() const { return ImageView<const uint16_t>(depth, width, height); }
  ImageView<const Rgb8> colour_view() const {
    return has_colour ? ImageView<const Rgb8>(colour, width, height) : ImageView<const Rgb8>();
  }
  ImageView<const uint16_t> amplitude_view() const {
    return has_amplitude ? ImageView<const uint16_t>(amplitude, width, height) : ImageView<const uint16_t>();
  }
  //! True when a width x height image fits the buffers.
  //! \param w width in pixels  \param h height in pixels
  bool fits(int w, int h) const {
    return w > 0 && h > 0 && depth != nullptr && std::size_t(w) * std::size_t(h) <= std::size_t(capacity_pixels);
  }
};

//! Static storage for one frame of up to Pixels pixels (put it in .bss, never on the stack).
template <int Pixels>
struct DepthFrameStorage {
  uint16_t depth[Pixels];
  Rgb8 colour[Pixels];
  uint16_t amplitude[Pixels];
  //! A frame pointing at this storage.
  DepthFrame frame() {
    DepthFrame f;
    f.depth = depth;
    f.colour = colour;
    f.amplitude = amplitude;
    f.capacity_pixels = Pixels;
    return f;
  }
};

}  // namespace edgefuse::hal
