// One pass over the messages of several topics in record order: a chunk that holds INS messages
// and a cloud (ROS 1 bags: every chunk of a drive) is then decompressed once for both, where a
// pass per topic would decompress it twice. Runs in parallel over contiguous runs of messages.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "recording/bag_reader.hpp"
#include "recording/messages.hpp"

namespace insalign::io {

struct TopicPass {
  std::uint32_t topic = 0;
  std::size_t prefix_bytes = 0;  ///< 0: the whole message; else BagReader::read_prefix
  /// Called once per message, index = its position in reader.messages(topic), from worker
  /// threads (handlers write to their own slot for the index).
  std::function<void(std::size_t index, const bag::MessageRef& ref, bag::Bytes bytes)> on_message;
};

/// Reads every message of every pass, merged in record order. Exceptions of a handler or the
/// reader propagate (the first one).
void read_in_record_order(const bag::BagReader& reader, const std::vector<TopicPass>& passes);

}  // namespace insalign::io
