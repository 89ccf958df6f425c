#include "common/allocator.h"

#include <malloc.h>

namespace ragdoll::allocator {

void KeepLargeBlocks() {
  // Setting either also stops glibc's dynamic threshold, so both are set.
  mallopt(M_MMAP_THRESHOLD, static_cast<int>(kKeptBytes));
  mallopt(M_TRIM_THRESHOLD, static_cast<int>(kKeptBytes));
}

}  // namespace ragdoll::allocator
