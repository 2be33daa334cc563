// Counts heap allocations made by this process (every malloc family call, so operator new,
// std::vector, Eigen's dynamic types and C libraries are all seen). Link alloc_counter.cpp into a
// test to use it.
#pragma once

namespace edgefuse_test {

//! Starts counting from zero.
void alloc_count_start();
//! Allocations since alloc_count_start().
long alloc_count();

}  // namespace edgefuse_test
