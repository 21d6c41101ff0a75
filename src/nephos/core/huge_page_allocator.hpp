#pragma once
// A std::allocator for large, randomly accessed arrays (3D textures sampled along rays that
// jump kilometres between pixels). With 4 KiB pages a 32 MiB texture spans 8192 pages, more
// than the CPU's second-level TLB holds, so nearly every random fetch also pays a page walk.
// Allocations of 2 MiB or more are aligned to 2 MiB and marked MADV_HUGEPAGE before their
// first touch, so Linux backs them with transparent huge pages where it can (the default
// "madvise" policy of Debian). Elsewhere, or if the kernel declines, it is a plain aligned
// allocation: only speed differs, never results. Smaller allocations are aligned to a cache
// line (64 bytes), which the lattice kernels' streaming stores need.
//
// `MinHugeBytes` lowers that threshold for tables that are small but read at random on every
// sample (block bounds, cube maps): those are rounded up to whole 2 MiB pages, trading up to
// 2 MiB of memory per table for TLB reach. Under a hypervisor's nested paging a TLB miss walks
// two page tables, and the renderer's tables of 4 KiB pages (about 15 MiB) are more than a
// core's second-level TLB covers (2048 entries on common x86-64 cores).
#include <cstddef>
#include <cstdlib>
#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace nephos {

template <class T, std::size_t MinHugeBytes = std::size_t{2} << 20>
struct HugePageAllocator {
  using value_type = T;
  template <class U>
  struct rebind {
    using other = HugePageAllocator<U, MinHugeBytes>;
  };
  static constexpr std::size_t huge_page_bytes = std::size_t{2} << 20;
  static constexpr std::size_t cache_line_bytes = 64;

  HugePageAllocator() = default;
  template <class U>
  HugePageAllocator(const HugePageAllocator<U, MinHugeBytes>&) noexcept {}

  T* allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
    if (bytes < MinHugeBytes) {  // cache-line aligned, so streaming stores apply at any size
      if (void* p =
              std::aligned_alloc(cache_line_bytes, (bytes + cache_line_bytes) / cache_line_bytes * cache_line_bytes))
        return static_cast<T*>(p);
      throw std::bad_alloc();
    }
    const std::size_t rounded = (bytes + huge_page_bytes - 1) / huge_page_bytes * huge_page_bytes;
    void* p = std::aligned_alloc(huge_page_bytes, rounded);
    if (!p) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    madvise(p, rounded, MADV_HUGEPAGE);  // advisory: failure only means 4 KiB pages
#endif
    return static_cast<T*>(p);
  }
  void deallocate(T* p, std::size_t) noexcept { std::free(p); }

  template <class U>
  bool operator==(const HugePageAllocator<U, MinHugeBytes>&) const noexcept {
    return true;
  }
};

/// HugePageAllocator for randomly read lookup tables of 256 KiB or more.
template <class T>
using TableAllocator = HugePageAllocator<T, std::size_t{256} << 10>;

}  // namespace nephos
