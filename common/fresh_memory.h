// Large arrays faulted in by the kernel in one call instead of one page fault per 4 KiB page.
//
// A fresh multi-megabyte allocation is a new mapping: its first write to each page traps into
// the kernel, which zeroes the page and maps it. On the 2-core VMs penumbra is measured on, the
// traps cost about as much as the zeroing (240 MB: 0.145 s page by page, 0.115 s populated;
// docs/oracle.md section 9). MADV_POPULATE_WRITE (Linux 5.14) maps the whole range at once;
// where the kernel lacks it, nothing changes.
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <vector>

namespace penumbra {

// Faults in the whole pages of [data, data + bytes) for writing, if the kernel can. Not as
// transparent huge pages: on those VMs they came from memory the host had not yet backed, and
// filling the frame took twice as long (docs/oracle.md section 9).
inline void populate_for_writing(void* data, std::size_t bytes) {
#ifdef MADV_POPULATE_WRITE
    static const std::uintptr_t page = static_cast<std::uintptr_t>(::sysconf(_SC_PAGESIZE));
    const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(data) + page - 1) & ~(page - 1);
    const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(data) + bytes) & ~(page - 1);
    if (end > begin) ::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_POPULATE_WRITE);
#else
    (void)data;
    (void)bytes;
#endif
}

// v.assign(n, value), with v's storage populated first when it is newly allocated.
template <typename T>
void assign_populated(std::vector<T>& v, std::size_t n, const T& value) {
    if (v.capacity() < n) {
        std::vector<T>().swap(v);
        v.reserve(n);
        populate_for_writing(v.data(), n * sizeof(T));
    }
    v.assign(n, value);
}

}  // namespace penumbra
