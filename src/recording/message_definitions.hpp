// Message definitions: the built-in ones for every type insalign decodes (what the bag writers
// store, and what a stored definition is checked against), a parser for the .msg text that ROS 1
// bags (connection headers), MCAP schemas (ros1msg / ros2msg) and rosbag2 (message_definitions)
// store, and the md5sum of ROS 1 computed the way genmsg does.
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "recording/bag_reader.hpp"
#include "recording/messages.hpp"

namespace insalign::io::bag {

/// The built-in definition of one message type.
struct MessageDefinition {
  std::string type;       ///< ROS 1 name, "sensor_msgs/PointCloud2"
  std::string ros2_type;  ///< "sensor_msgs/msg/PointCloud2"
  /// The full text as rosbag stores it in a connection header: the type's .msg, then one
  /// "====...\nMSG: pkg/Type\n" section per dependency (depth first). Comments are left out.
  std::string ros1_text;
  std::string ros1_md5;  ///< as genmsg computes it (comments and whitespace do not change it)
  /// The ros2msg text as rosbag2 and MCAP writers store it (same sectioning, ROS 2 field types).
  std::string ros2_text;
};

/// Every type insalign decodes.
const std::vector<MessageDefinition>& builtin_definitions();
/// The built-in definition of `type` (either spelling), or nullptr.
const MessageDefinition* builtin_definition(const std::string& type);
/// The Oem7Header layout the built-in definitions use: ROS 1 kBase, ROS 2 kReceiverStatus.
Oem7Header::Layout builtin_oem7_layout(MessageEncoding encoding);

// ------------------------------------------------------------------------------------ parsing

struct MsgField {
  std::string type;  ///< primitive ("float64", "string", "time") or message ("geometry_msgs/Pose")
  std::string name;
  bool is_array = false;
  std::size_t array_size = 0;   ///< fixed-size arrays ([N]); 0 for variable ([] and [<=N])
  std::size_t upper_bound = 0;  ///< [<=N] (ROS 2); 0 if unbounded
  bool is_primitive() const;
};
struct MsgConstant {
  std::string type, name, value;  ///< value as written (trimmed)
};
struct MsgSpec {
  std::string type;
  std::vector<MsgConstant> constants;
  std::vector<MsgField> fields;
};
struct MsgDefinition {
  std::string main_type;
  std::map<std::string, MsgSpec> specs;  ///< the main type and every "MSG:" section
  const MsgSpec* find(const std::string& type) const;
};

/// Parses a full definition text of `type` (ros2: ROS 2 .msg rules and type names). Field types
/// are resolved to "pkg/Type" (ROS 1 "Header" is std_msgs/Header; "pkg/msg/Type" loses "/msg/").
/// Throws InputError(where, "line N", what).
MsgDefinition parse_message_definition(const std::string& type, const std::string& text, bool ros2,
                                       const std::string& where);

/// md5sum of `type` as genmsg computes it from its ROS 1 full text (all dependencies must be in
/// it). Throws InputError(where, ...) if the text does not parse or lacks a dependency.
std::string ros1_md5sum(const std::string& type, const std::string& full_text, const std::string& where);

/// MD5 of bytes, lower-case hex (RFC 1321).
std::string md5_hex(const std::string& bytes);

// ----------------------------------------------------------------------------------- checking

struct DefinitionCheck {
  bool checked = false;               ///< a stored definition was compared with the built-in one
  std::vector<std::string> warnings;  ///< md5sum mismatch, no definition stored, IDL, ...
  std::optional<Oem7Header::Layout> oem7_layout;  ///< novatel_oem7_msgs types: from the definition
};

/// Checks the definition the container stored for `topic` (ros1msg or ros2msg text with its
/// "MSG: pkg/Type" sections) against the built-in one: the fields insalign reads must be there,
/// with the same types, in the same order (nested messages expanded). A mismatch (a custom fork
/// of the message) throws InputError(source or topic, "topic T", naming the first differing
/// field). A ROS 1 md5sum that differs from the built-in one while the fields match is a warning.
/// Types insalign does not decode are not checked (a warning says so).
DefinitionCheck check_definition(const Topic& topic, const std::string& source = "");

}  // namespace insalign::io::bag
