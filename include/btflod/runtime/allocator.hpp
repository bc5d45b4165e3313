// btflod — allocator callbacks for the runtime (RuntimeAllocator, core/allocator.hpp; what
// libdeflate's libdeflate_set_memory_allocator and VMA's VkAllocationCallbacks give an engine):
// every buffer a runtime object allocates at creation goes through them, nothing allocates
// afterwards. RuntimeAllocator, CallbackAllocator<T> and RuntimeArray<T> live in
// core/allocator.hpp (stream/ and vt/ use them too); this header names them for the runtime.
#pragma once

#include "btflod/core/allocator.hpp"
