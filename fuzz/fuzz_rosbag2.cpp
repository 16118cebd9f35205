// Any input must either read or throw InputError: no crash, hang or sanitizer report. Two modes,
// chosen by the content so that neither corpus needs a selector byte: an input with the sqlite3
// header is a .db3 file given to open_bag (topics listed, every message read); anything else is a
// metadata.yaml, parsed and then opened as the yaml of a scratch rosbag2 folder.
#include <unistd.h>

#include <string_view>

#include "core/errors.hpp"
#include "fuzz_common.hpp"
#include "recording/rosbag2.hpp"

namespace {

void read_everything(const insalign::io::bag::BagReader& bag) {
  (void)bag.describe();
  for (std::uint32_t t = 0; t < bag.topics().size(); ++t) {
    for (const insalign::io::bag::MessageRef& ref : bag.messages(t)) {
      (void)bag.read(ref);
      (void)bag.read_prefix(ref, 16);
    }
  }
}

// A scratch rosbag2 folder holding two small valid .db3 files (bag_0.db3, bag_1.db3, written by
// insalign's writer once) for the fuzzed metadata.yaml to name.
const std::filesystem::path& scratch_folder() {
  namespace fs = std::filesystem;
  static const fs::path folder = [] {
    const fs::path dir = fs::temp_directory_path() / ("insalign-fuzz-rosbag2-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    auto writer = insalign::io::bag::make_rosbag2_writer(dir / "seed", {});
    const std::uint32_t a = writer->add_topic(
        {"/chatter", "std_msgs/String", insalign::io::bag::MessageEncoding::kCdr, "string data", "ros2msg", "", 0});
    const std::uint32_t b =
        writer->add_topic({"/imu", "sensor_msgs/msg/Imu", insalign::io::bag::MessageEncoding::kCdr, "", "", "", 0});
    writer->write(a, 1000, {0, 1, 0, 0, 3, 0, 0, 0, 'h', 'i', 0});
    writer->write(b, 1500, {0, 1, 0, 0});
    writer->write(a, 2000, {});
    writer->close();
    fs::copy_file(dir / "seed" / "seed_0.db3", dir / "bag_0.db3");
    fs::copy_file(dir / "seed" / "seed_0.db3", dir / "bag_1.db3");
    return dir;
  }();
  return folder;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace bag = insalign::io::bag;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
    if (bag::is_sqlite3(bytes)) {
      read_everything(*bag::open_bag(insalign::fuzz::scratch_file(".db3", data, size)));
    } else {
      const std::filesystem::path yaml = scratch_folder() / "metadata.yaml";
      (void)bag::parse_rosbag2_metadata(bytes, yaml.string());
      std::FILE* f = std::fopen(yaml.c_str(), "wb");
      if (f == nullptr) return 0;
      std::fwrite(data, 1, size, f);
      std::fclose(f);
      read_everything(*bag::open_bag(scratch_folder()));
    }
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
