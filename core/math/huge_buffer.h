// An allocator for large flat arrays (the hierarchy's tables): blocks of 4 MiB and more are 2 MiB
// aligned and marked for transparent huge pages before first touch, because the lifting stencils
// gather across hundreds of MiB of tables and 4 KiB pages make that TLB-bound.
#pragma once

#include <sys/mman.h>

#include <cstdlib>
#include <new>
#include <vector>

namespace tesswave {

template <class T>
struct HugePageAllocator {
    using value_type = T;
    static constexpr size_t kHuge = size_t{2} << 20;

    HugePageAllocator() = default;
    template <class U>
    HugePageAllocator(const HugePageAllocator<U>&) noexcept {}

    T* allocate(size_t count) {
        const size_t bytes = count * sizeof(T);
        if (bytes < 2 * kHuge) return std::allocator<T>{}.allocate(count);
        const size_t rounded = (bytes + kHuge - 1) / kHuge * kHuge;
        void* p = std::aligned_alloc(kHuge, rounded);
        if (!p) throw std::bad_alloc();
        ::madvise(p, rounded, MADV_HUGEPAGE);  // a hint: failure only costs speed
        return static_cast<T*>(p);
    }
    void deallocate(T* p, size_t count) noexcept {
        if (count * sizeof(T) < 2 * kHuge) {
            std::allocator<T>{}.deallocate(p, count);
        } else {
            std::free(p);
        }
    }
    template <class U>
    bool operator==(const HugePageAllocator<U>&) const noexcept {
        return true;
    }
};

template <class T>
using HugeVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace tesswave
