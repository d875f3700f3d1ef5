// The allocator of the arrays that queries read at random (bodies, records, the name table, the
// grid's cells and entries): blocks of 2 MiB and more are aligned to 2 MiB and offered to the
// kernel as huge pages (Linux madvise MADV_HUGEPAGE), so that one TLB entry covers 2 MiB
// rather than 4 KiB. At 10^5 bodies a random query otherwise pays a page walk on most of its
// loads. Smaller blocks, other systems, or a kernel that declines: the plain allocator's pages.
// It changes where arrays live, never what they hold.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <memory>
#include <new>
#include <vector>

#ifdef __linux__
#include <sys/mman.h>
#endif

namespace vadop {
namespace detail {

template <class T>
struct LargeArrayAllocator {
  using value_type = T;
  static constexpr size_t kHugePage = size_t{2} << 20;

  LargeArrayAllocator() noexcept = default;
  template <class U>
  LargeArrayAllocator(const LargeArrayAllocator<U>&) noexcept {}  // NOLINT(google-explicit-constructor)

  T* allocate(size_t n) {
    if (n > static_cast<size_t>(-1) / sizeof(T)) throw std::bad_array_new_length();
    if (!huge(n)) return std::allocator<T>().allocate(n);
    const size_t bytes = rounded(n);
    void* p = std::aligned_alloc(kHugePage, bytes);
    if (p == nullptr) throw std::bad_alloc();
#ifdef __linux__
    madvise(p, bytes, MADV_HUGEPAGE);  // a hint: on failure the pages stay 4 KiB
#endif
    return static_cast<T*>(p);
  }
  void deallocate(T* p, size_t n) noexcept {
    if (huge(n)) {
      std::free(p);
    } else {
      std::allocator<T>().deallocate(p, n);
    }
  }

  template <class U>
  bool operator==(const LargeArrayAllocator<U>&) const noexcept { return true; }
  template <class U>
  bool operator!=(const LargeArrayAllocator<U>&) const noexcept { return false; }

 private:
  static_assert(alignof(T) <= kHugePage, "aligned to at most a huge page");
  static bool huge(size_t n) { return n * sizeof(T) >= kHugePage; }
  static size_t rounded(size_t n) { return (n * sizeof(T) + kHugePage - 1) / kHugePage * kHugePage; }
};

// A std::vector on LargeArrayAllocator.
template <class T>
using LargeArray = std::vector<T, LargeArrayAllocator<T>>;

}  // namespace detail
}  // namespace vadop
