// Any bytes, decoded as a PointCloud2 (to a Sweep) and as every INS message in both encodings,
// and read as message definition text: each either decodes or throws InputError; no crash, hang
// or sanitizer report.
#include <string>

#include "core/errors.hpp"
#include "recording/message_definitions.hpp"
#include "recording/messages.hpp"
#include "recording/pointcloud2.hpp"

namespace {

using namespace insalign::io::bag;

template <typename F>
void expect_input_error_only(F&& f) {
  try {
    f();
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const Bytes bytes(data, size);
  for (const MessageEncoding enc : {MessageEncoding::kRos1, MessageEncoding::kCdr}) {
    expect_input_error_only([&] {
      PointCloudInfo info;
      (void)decode_sweep(bytes, enc, "fuzz", &info);
    });
    expect_input_error_only([&] { (void)to_ins_record(decode_oem7_inspva(bytes, enc, "fuzz")); });
    expect_input_error_only([&] { (void)to_ins_record(decode_oem7_inspvax(bytes, enc, "fuzz")); });
    expect_input_error_only([&] { (void)to_ins_record(decode_novatel_gps_inspva(bytes, enc, "fuzz")); });
    expect_input_error_only([&] { (void)to_ins_record(decode_novatel_gps_inspvax(bytes, enc, "fuzz")); });
    expect_input_error_only([&] { (void)to_ins_record(decode_navsatfix(bytes, enc, "fuzz")); });
    expect_input_error_only([&] { (void)imu_orientation(decode_imu(bytes, enc, "fuzz"), "fuzz"); });
    expect_input_error_only([&] { (void)to_ins_record(decode_odometry(bytes, enc, "fuzz"), "fuzz"); });
    expect_input_error_only([&] { (void)to_ins_record(decode_pose_stamped(bytes, enc, "fuzz"), "fuzz"); });
    expect_input_error_only([&] {
      for (const TransformStamped& tf : decode_tf_message(bytes, enc, "fuzz").transforms) (void)transform_from(tf, "fuzz");
    });
  }
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (const bool ros2 : {false, true}) {
    expect_input_error_only([&] {
      const Topic topic{"/fuzz", "sensor_msgs/PointCloud2", ros2 ? MessageEncoding::kCdr : MessageEncoding::kRos1, text,
                        ros2 ? "ros2msg" : "ros1msg", "", 0};
      (void)check_definition(topic);
    });
  }
  expect_input_error_only([&] { (void)ros1_md5sum("fuzz/Msg", text, "fuzz"); });
  return 0;
}
