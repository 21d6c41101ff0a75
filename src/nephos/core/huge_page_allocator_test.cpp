#include "nephos/core/huge_page_allocator.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <type_traits>
#include <vector>

namespace nephos {
namespace {
std::uintptr_t address(const void* p) { return reinterpret_cast<std::uintptr_t>(p); }
constexpr std::uintptr_t huge_page = std::uintptr_t{2} << 20;
}  // namespace

TEST(HugePageAllocator, AlignsLargeArraysToHugePagesAndSmallOnesToCacheLines) {
  // The lattice kernels' streaming stores need 64-byte alignment at any size; THP needs the
  // 2 MiB alignment (the kernel backs only aligned 2 MiB ranges with a huge page).
  std::vector<float, HugePageAllocator<float>> small(1000), large((std::size_t{3} << 20) / sizeof(float));
  EXPECT_EQ(address(small.data()) % 64, 0u);
  EXPECT_EQ(address(large.data()) % huge_page, 0u);
  // 512 KiB: below the default threshold, at or above the lookup tables' one.
  const std::size_t n = (std::size_t{512} << 10) / sizeof(std::uint16_t);
  std::vector<std::uint16_t, HugePageAllocator<std::uint16_t>> plain(n);
  std::vector<std::uint16_t, TableAllocator<std::uint16_t>> table(n);
  EXPECT_EQ(address(plain.data()) % 64, 0u);
  EXPECT_EQ(address(table.data()) % huge_page, 0u);
  table[n - 1] = 7;  // the whole requested range is usable
  EXPECT_EQ(table[n - 1], 7);
}

// Containers rebind their allocator (a vector's debug proxies, a list's nodes): the threshold
// must travel with it.
static_assert(
    std::is_same_v<std::allocator_traits<TableAllocator<float>>::rebind_alloc<double>, TableAllocator<double>>);

}  // namespace nephos
