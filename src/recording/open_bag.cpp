// The one entry point over every recording container: a file is recognised by its first bytes
// (never its extension), a folder is a rosbag2 bag; a bag split across files reads as one.
#include <algorithm>
#include <fstream>
#include <map>
#include <mutex>
#include <stdexcept>
#include <tuple>

#include "core/errors.hpp"
#include "recording/bag_reader.hpp"
#include "recording/bag_writer.hpp"
#include "recording/mcap.hpp"
#include "recording/ros1_bag.hpp"
#include "recording/rosbag2.hpp"

namespace insalign::io::bag {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kMagicProbeBytes = 16;

std::string printable_start(std::string_view bytes) {
  if (bytes.empty()) return "the file is empty";
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out = "starts with \"";
  for (const char c : bytes) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7f && c != '"' && c != '\\') {
      out += c;
    } else {
      out += "\\x";
      out += kHex[u >> 4];
      out += kHex[u & 0xf];
    }
  }
  return out + "\"";
}

std::unique_ptr<BagReader> open_bag_file(const fs::path& path, const OpenOptions& options) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    throw InputError(path.string(), "", fs::exists(path, ec) ? "not a regular file or folder" : "file not found");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "", "cannot open");
  std::string first(kMagicProbeBytes, '\0');
  in.read(first.data(), static_cast<std::streamsize>(first.size()));
  first.resize(static_cast<std::size_t>(in.gcount()));
  if (is_ros1_bag(first)) return open_ros1_bag(path, options);
  if (is_mcap(first)) return open_mcap(path);
  if (is_sqlite3(first)) return open_rosbag2_db3(path);
  throw InputError(path.string(), "byte 0",
                   "not a ROS 1 bag, MCAP or rosbag2 sqlite3 file (" + printable_start(first) + ")");
}

std::unique_ptr<BagReader> open_bag_folder(const fs::path& folder, const OpenOptions& options) {
  std::vector<std::string> warnings;
  const std::vector<fs::path> files = rosbag2_folder_files(folder, warnings);
  std::vector<std::unique_ptr<BagReader>> parts;
  parts.reserve(files.size());
  for (const fs::path& file : files) parts.push_back(open_bag_file(file, options));
  return concatenate_bags(std::move(parts), folder, std::move(warnings));
}

// A split bag read as one: each merged topic lists where it lives in each file, and its index
// (built on first use, once) keeps every message's own reader's ref, so that any container's
// locators survive; the merged ref's locator points into that list, locator2 names the file.
class SplitBagReader final : public BagReader {
 public:
  SplitBagReader(std::vector<std::unique_ptr<BagReader>> parts, fs::path path, std::vector<std::string> warnings);

  const std::vector<Topic>& topics() const override { return topics_; }
  std::vector<MessageRef> messages(std::uint32_t topic) const override;
  std::vector<std::uint8_t> read(const MessageRef& ref) const override;
  std::vector<std::uint8_t> read_prefix(const MessageRef& ref, std::size_t max_bytes) const override;
  std::string describe() const override { return describe_; }
  const std::vector<std::string>& warnings() const override { return warnings_; }
  std::int64_t start_time_ns() const override { return start_ns_; }
  std::int64_t end_time_ns() const override { return end_ns_; }
  const fs::path& path() const override { return path_; }

 private:
  struct Source {
    std::uint32_t part = 0;
    std::uint32_t topic = 0;  ///< the topic's index in that part
  };
  struct TopicIndex {
    std::once_flag built;
    std::vector<MessageRef> inner;    ///< in merged order
    std::vector<std::uint32_t> part;  ///< the file of each
  };

  void merge_topics();
  const TopicIndex& index(std::uint32_t topic) const;
  /// The part holding `ref` and that part's own ref for it.
  std::pair<const BagReader*, MessageRef> locate(const MessageRef& ref) const;

  std::vector<std::unique_ptr<BagReader>> parts_;
  fs::path path_;
  std::vector<std::string> warnings_;
  std::vector<Topic> topics_;
  std::vector<std::vector<Source>> sources_;  ///< per merged topic
  std::vector<std::unique_ptr<TopicIndex>> indexes_;
  std::string describe_;
  std::int64_t start_ns_ = 0;
  std::int64_t end_ns_ = 0;
};

SplitBagReader::SplitBagReader(std::vector<std::unique_ptr<BagReader>> parts, fs::path path,
                               std::vector<std::string> warnings)
    : parts_(std::move(parts)), path_(std::move(path)), warnings_(std::move(warnings)) {
  merge_topics();
  std::vector<std::string> kinds;
  bool any = false;
  for (const auto& part : parts_) {
    for (const std::string& w : part->warnings()) warnings_.push_back(part->path().filename().string() + ": " + w);
    if (std::find(kinds.begin(), kinds.end(), part->describe()) == kinds.end()) kinds.push_back(part->describe());
    const bool has_messages = part->start_time_ns() != 0 || part->end_time_ns() != 0;
    if (!has_messages) continue;
    start_ns_ = any ? std::min(start_ns_, part->start_time_ns()) : part->start_time_ns();
    end_ns_ = any ? std::max(end_ns_, part->end_time_ns()) : part->end_time_ns();
    any = true;
  }
  describe_ = "rosbag2 folder, " + std::to_string(parts_.size()) + (parts_.size() == 1 ? " file: " : " files: ");
  for (std::size_t i = 0; i < kinds.size(); ++i) describe_ += (i > 0 ? "; " : "") + kinds[i];
}

void SplitBagReader::merge_topics() {
  std::map<std::tuple<std::string, std::string, MessageEncoding>, std::uint32_t> merged;
  std::map<std::string, std::string> type_of_name;
  for (std::uint32_t p = 0; p < parts_.size(); ++p) {
    const std::vector<Topic>& topics = parts_[p]->topics();
    for (std::uint32_t t = 0; t < topics.size(); ++t) {
      const Topic& topic = topics[t];
      const auto key = std::make_tuple(topic.name, normalized_type(topic.type), topic.encoding);
      auto [it, inserted] = merged.emplace(key, static_cast<std::uint32_t>(topics_.size()));
      if (inserted) {
        const auto [named, fresh] = type_of_name.emplace(topic.name, topic.type);
        if (!fresh) {
          warnings_.push_back("topic " + topic.name + " has type " + topic.type + " in " +
                              parts_[p]->path().filename().string() + " but " + named->second + " before: kept apart");
        }
        topics_.push_back(topic);
        topics_.back().message_count = 0;
        sources_.emplace_back();
      }
      Topic& into = topics_[it->second];
      into.message_count += topic.message_count;
      if (into.definition.empty()) {
        into.definition = topic.definition;
        into.definition_encoding = topic.definition_encoding;
      }
      if (into.md5sum.empty()) into.md5sum = topic.md5sum;
      sources_[it->second].push_back(Source{p, t});
    }
  }
  for (std::size_t i = 0; i < topics_.size(); ++i) indexes_.push_back(std::make_unique<TopicIndex>());
}

const SplitBagReader::TopicIndex& SplitBagReader::index(std::uint32_t topic) const {
  if (topic >= topics_.size()) throw std::out_of_range("SplitBagReader: no topic " + std::to_string(topic));
  TopicIndex& idx = *indexes_[topic];
  std::call_once(idx.built, [&] {
    std::vector<std::pair<MessageRef, std::uint32_t>> all;
    for (const Source& s : sources_[topic]) {
      for (const MessageRef& ref : parts_[s.part]->messages(s.topic)) all.emplace_back(ref, s.part);
    }
    // Each file's list is already in time order; the stable sort keeps file order for ties.
    std::stable_sort(all.begin(), all.end(),
                     [](const auto& a, const auto& b) { return a.first.log_time_ns < b.first.log_time_ns; });
    idx.inner.reserve(all.size());
    idx.part.reserve(all.size());
    for (const auto& [ref, part] : all) {
      idx.inner.push_back(ref);
      idx.part.push_back(part);
    }
  });
  return idx;
}

std::vector<MessageRef> SplitBagReader::messages(std::uint32_t topic) const {
  const TopicIndex& idx = index(topic);
  std::vector<MessageRef> out(idx.inner.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i].topic = topic;
    out[i].log_time_ns = idx.inner[i].log_time_ns;
    out[i].locator = i;
    out[i].locator2 = idx.part[i];
  }
  return out;
}

std::pair<const BagReader*, MessageRef> SplitBagReader::locate(const MessageRef& ref) const {
  const TopicIndex& idx = index(ref.topic);
  if (ref.locator >= idx.inner.size() || idx.part[ref.locator] != ref.locator2) {
    throw std::out_of_range("SplitBagReader: not a message of this bag");
  }
  return {parts_[ref.locator2].get(), idx.inner[ref.locator]};
}

std::vector<std::uint8_t> SplitBagReader::read(const MessageRef& ref) const {
  const auto [part, inner] = locate(ref);
  return part->read(inner);
}

std::vector<std::uint8_t> SplitBagReader::read_prefix(const MessageRef& ref, std::size_t max_bytes) const {
  const auto [part, inner] = locate(ref);
  return part->read_prefix(inner, max_bytes);
}

}  // namespace

std::unique_ptr<BagReader> concatenate_bags(std::vector<std::unique_ptr<BagReader>> parts,
                                            const std::filesystem::path& path, std::vector<std::string> warnings) {
  return std::make_unique<SplitBagReader>(std::move(parts), path, std::move(warnings));
}

std::unique_ptr<BagReader> open_bag(const std::filesystem::path& path, const OpenOptions& options) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return open_bag_folder(path, options);
  // The yaml of a rosbag2 folder stands for its folder.
  if (path.filename() == "metadata.yaml" && fs::is_regular_file(path, ec)) return open_bag_folder(path.parent_path(), options);
  return open_bag_file(path, options);
}

std::string normalized_type(const std::string& type) {
  const auto slash = type.find('/');
  if (slash == std::string::npos || type.compare(slash, 5, "/msg/") != 0) return type;
  if (type.find('/', slash + 5) != std::string::npos) return type;
  return type.substr(0, slash) + type.substr(slash + 4);
}

std::unique_ptr<BagWriter> make_bag_writer(BagFormat format, const std::filesystem::path& path,
                                           const WriterOptions& options) {
  switch (format) {
    case BagFormat::kDb3:
      return make_rosbag2_writer(path, options);
    case BagFormat::kRos1:
      return make_ros1_bag_writer(path, options);
    case BagFormat::kMcap:
      return make_mcap_writer(path, options);
  }
  throw std::invalid_argument("make_bag_writer: unknown BagFormat");
}

}  // namespace insalign::io::bag
