#pragma once
// Counts heap allocations in the test executable (global operator new is
// replaced once, in test_alloc_counter.cpp), to prove that step() never allocates.
#include <cstddef>

namespace hysteron_test {
// Number of calls to global operator new since the program started.
std::size_t allocations() noexcept;
}  // namespace hysteron_test
