// The C library's allocator, set for processes that allocate and free tensors of tens of
// megabytes many times a second.
#pragma once

namespace ragdoll::allocator {

// glibc serves blocks above 128 kB (rising with use, capped at 32 MB) with fresh mmap()ed pages
// and returns freed heap tops to the system, so each PPO update faulted in its large
// activations and gradients anew; page faults are expensive on virtual machines. This keeps
// blocks up to kKeptBytes in the heap and freed memory with the process, which then holds its
// peak use (measured in docs/benchmarks.md). Call once, first thing in main().
void KeepLargeBlocks();

// Blocks up to this size come from the heap and freed memory up to this size stays with it.
constexpr long kKeptBytes = 512L << 20;

}  // namespace ragdoll::allocator
