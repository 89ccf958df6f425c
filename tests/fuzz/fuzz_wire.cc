// libFuzzer target: the wire codec on arbitrary bytes, as the broker and learner meet them from
// the network. Every input must come back as a verdict, never a crash or undefined behaviour.
#include <cstddef>
#include <cstdint>

#include "common/wire.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace ragdoll;
  constexpr size_t kMax = 64 << 20;
  v1::Header header;
  size_t offset = 0;
  wire::ReadHeader(data, size, kMax, &header, &offset);
  v1::TrajectorySegment segment;
  if (wire::ReadMessage(data, size, kMax, &header, &segment).ok()) {
    // The sizes the shipped humanoid uses, and sizes taken from the segment itself.
    wire::CheckSegment(segment, 197, 36);
    if (segment.observations().shape_size() == 2 && segment.actions().shape_size() == 2) {
      wire::Verdict v =
          wire::CheckSegment(segment, static_cast<int>(segment.observations().shape(1)),
                             static_cast<int>(segment.actions().shape(1)));
      if (v.ok()) {
        // A checked segment's numbers are readable in full.
        volatile float sink = 0;
        for (float x : wire::FloatValues(segment.observations())) sink = sink + x;
      }
    }
  }
  v1::PolicySnapshot snapshot;
  if (wire::ReadMessage(data, size, kMax, &header, &snapshot).ok()) wire::CheckSnapshot(snapshot);
  v1::ReplicaHello hello;
  wire::ReadMessage(data, size, kMax, &header, &hello);
  return 0;
}
