#pragma once
// Counts heap allocations in the test executable. tests/test_alloc_counter.cpp
// replaces the global operator new/delete (once per executable) and increments
// a global atomic counter on every allocation.
#include <cstddef>

namespace hysteron_test {
// Number of calls to any global operator new since program start.
std::size_t allocations() noexcept;
}  // namespace hysteron_test
