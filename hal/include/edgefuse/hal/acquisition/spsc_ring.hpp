// A lock-free single-producer single-consumer ring of N - 1 usable entries (N a power of two):
// one thread pushes, one thread pops, no locks, no allocation. Acquire/release ordering hands the
// entry's contents (and the frame it names) from one thread to the other.
#pragma once

#include <atomic>
#include <cstdint>

namespace edgefuse::hal {

template <class T, uint32_t N>
class SpscRing {
  static_assert(N >= 2 && (N & (N - 1)) == 0, "N must be a power of two");

 public:
  //! Producer side. False when full.
  //! \param value the entry to append
  bool push(const T& value) {
    const uint32_t head = head_.load(std::memory_order_relaxed);
    const uint32_t next = (head + 1) & (N - 1);
    if (next == tail_.load(std::memory_order_acquire)) return false;
    items_[head] = value;
    head_.store(next, std::memory_order_release);
    return true;
  }
  //! Consumer side. False when empty.
  //! \param value receives the oldest entry
  bool pop(T& value) {
    const uint32_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    value = items_[tail];
    tail_.store((tail + 1) & (N - 1), std::memory_order_release);
    return true;
  }
  bool empty() const { return head_.load(std::memory_order_acquire) == tail_.load(std::memory_order_acquire); }
  static constexpr uint32_t capacity() { return N - 1; }

 private:
  T items_[N];
  alignas(64) std::atomic<uint32_t> head_{0};  // written by the producer only
  alignas(64) std::atomic<uint32_t> tail_{0};  // written by the consumer only
};

}  // namespace edgefuse::hal
