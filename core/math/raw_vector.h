// Vectors whose resize leaves new elements uninitialized (default-initialized), for large buffers
// that are written whole right after they are sized: std::vector<T>::resize zeroes them first, a
// pass over memory on one core that a 1280x720 render plan paid for 7 MB of entries every frame.
// Only for trivial element types; read nothing before it is written.
#pragma once

#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace tesswave {

template <class T>
struct DefaultInitAllocator : std::allocator<T> {
    static_assert(std::is_trivially_default_constructible_v<T>);
    template <class U>
    struct rebind {
        using other = DefaultInitAllocator<U>;
    };
    DefaultInitAllocator() = default;
    template <class U>
    DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}

    // resize(n) and vector(n): nothing written.
    template <class U>
    void construct(U* p) noexcept {
        ::new (static_cast<void*>(p)) U;
    }
    // Everything else (copies, assign, push_back) as std::allocator does it.
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

template <class T>
using RawVector = std::vector<T, DefaultInitAllocator<T>>;

}  // namespace tesswave
