#include "recording/message_definitions.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <fmt/format.h>
#include <functional>
#include <limits>
#include <set>
#include <stdexcept>
#include <sstream>
#include <string_view>

#include "core/errors.hpp"

namespace insalign::io::bag {

namespace {

// ------------------------------------------------------------------- the built-in .msg texts

// One .msg per type, without comments. ros2 empty: the same text as ROS 1. Constant names and
// values matter (genmsg hashes them), typos included.
struct Section {
  const char* type;
  const char* ros1;
  const char* ros2;
};

constexpr const char* kOem7HeaderBase = R"(uint16 OEM7MSGTYPE_LOG = 0
string message_name
uint16 message_id
uint8 message_type
uint32 sequence_number
uint8 time_status
uint16 gps_week_number
uint32 gps_week_milliseconds
)";

constexpr const char* kOem7HeaderReceiverStatus = R"(uint16 OEM7MSGTYPE_LOG = 0
string message_name
uint16 message_id
uint8 message_type
uint32 sequence_number
uint8 time_status
uint16 gps_week_number
uint32 gps_week_milliseconds
uint32 receiver_status
float32 idle_time
)";

const Section kSections[] = {
    {"std_msgs/Header", "uint32 seq\ntime stamp\nstring frame_id\n", "builtin_interfaces/Time stamp\nstring frame_id\n"},
    {"builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n", ""},
    {"geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n", ""},
    {"geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n", ""},
    {"geometry_msgs/Quaternion", "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
     "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"},
    {"geometry_msgs/Pose", "Point position\nQuaternion orientation\n", ""},
    {"geometry_msgs/PoseWithCovariance", "Pose pose\nfloat64[36] covariance\n", ""},
    {"geometry_msgs/Twist", "Vector3 linear\nVector3 angular\n", ""},
    {"geometry_msgs/TwistWithCovariance", "Twist twist\nfloat64[36] covariance\n", ""},
    {"geometry_msgs/PoseStamped", "Header header\nPose pose\n", "std_msgs/Header header\nPose pose\n"},
    {"geometry_msgs/PoseWithCovarianceStamped", "Header header\nPoseWithCovariance pose\n",
     "std_msgs/Header header\nPoseWithCovariance pose\n"},
    {"geometry_msgs/Transform", "Vector3 translation\nQuaternion rotation\n", ""},
    {"geometry_msgs/TransformStamped", "Header header\nstring child_frame_id\nTransform transform\n",
     "std_msgs/Header header\nstring child_frame_id\nTransform transform\n"},
    {"nav_msgs/Odometry",
     "Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
     "geometry_msgs/TwistWithCovariance twist\n",
     "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
     "geometry_msgs/TwistWithCovariance twist\n"},
    {"tf2_msgs/TFMessage", "geometry_msgs/TransformStamped[] transforms\n", ""},
    {"tf/tfMessage", "geometry_msgs/TransformStamped[] transforms\n", ""},
    {"sensor_msgs/PointField",
     "uint8 INT8    = 1\nuint8 UINT8   = 2\nuint8 INT16   = 3\nuint8 UINT16  = 4\nuint8 INT32   = 5\n"
     "uint8 UINT32  = 6\nuint8 FLOAT32 = 7\nuint8 FLOAT64 = 8\n"
     "string name\nuint32 offset\nuint8  datatype\nuint32 count\n",
     ""},
    {"sensor_msgs/PointCloud2",
     "Header header\nuint32 height\nuint32 width\nPointField[] fields\nbool    is_bigendian\n"
     "uint32  point_step\nuint32  row_step\nuint8[] data\nbool is_dense\n",
     "std_msgs/Header header\nuint32 height\nuint32 width\nPointField[] fields\nbool    is_bigendian\n"
     "uint32  point_step\nuint32  row_step\nuint8[] data\nbool is_dense\n"},
    {"sensor_msgs/NavSatStatus",
     "int8 STATUS_NO_FIX =  -1\nint8 STATUS_FIX =      0\nint8 STATUS_SBAS_FIX = 1\nint8 STATUS_GBAS_FIX = 2\n"
     "int8 status\nuint16 SERVICE_GPS =     1\nuint16 SERVICE_GLONASS = 2\nuint16 SERVICE_COMPASS = 4\n"
     "uint16 SERVICE_GALILEO = 8\nuint16 service\n",
     ""},
    {"sensor_msgs/NavSatFix",
     "Header header\nNavSatStatus status\nfloat64 latitude\nfloat64 longitude\nfloat64 altitude\n"
     "float64[9] position_covariance\nuint8 COVARIANCE_TYPE_UNKNOWN = 0\nuint8 COVARIANCE_TYPE_APPROXIMATED = 1\n"
     "uint8 COVARIANCE_TYPE_DIAGONAL_KNOWN = 2\nuint8 COVARIANCE_TYPE_KNOWN = 3\nuint8 position_covariance_type\n",
     "std_msgs/Header header\nNavSatStatus status\nfloat64 latitude\nfloat64 longitude\nfloat64 altitude\n"
     "float64[9] position_covariance\nuint8 COVARIANCE_TYPE_UNKNOWN = 0\nuint8 COVARIANCE_TYPE_APPROXIMATED = 1\n"
     "uint8 COVARIANCE_TYPE_DIAGONAL_KNOWN = 2\nuint8 COVARIANCE_TYPE_KNOWN = 3\nuint8 position_covariance_type\n"},
    {"sensor_msgs/Imu",
     "Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n"
     "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n"
     "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n",
     "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n"
     "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n"
     "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n"},
    // novatel_oem7_driver (github.com/novatel/novatel_oem7_driver, src/novatel_oem7_msgs/msg).
    {"novatel_oem7_msgs/Oem7Header", kOem7HeaderBase, kOem7HeaderReceiverStatus},
    {"novatel_oem7_msgs/InertialSolutionStatus",
     "uint32 INS_INACTIVE            =  0\nuint32 INS_ALIGNING            =  1\nuint32 INS_HIGH_VARIANCE       =  2\n"
     "uint32 INS_SOLUTION_GOOD       =  3\nuint32 INS_SOLUTION_FREE       =  6\nuint32 INS_ALIGNMENT_COMPLETE  =  7\n"
     "uint32 DETERMINING_ORIENTATION =  8\nuint32 WAITING_INITIAL_POS     =  9\nuint32 WAITING_AZIMUTH         = 10\n"
     "uint32 INITIALIZING_BIASES     = 11\nuint32 MOTION_DETECT           = 12\nuint32 status\n",
     ""},
    {"novatel_oem7_msgs/PositionOrVelocityType",
     "uint32 NONE = 0\nuint32 FIXEDPOS = 1\nuint32 FIXEDHEIGHT = 2\nuint32 DOPPLER_VELOCITY = 8\nuint32 SINGLE = 16\n"
     "uint32 PSRDIFF = 17\nuint32 WAAS = 18\nuint32 PROPAGATED = 19\nuint32 L1_FLOAT = 32\nuint32 NARROW_FLOAT = 34\n"
     "uint32 L1_INT = 48\nuint32 WIDE_INT = 49\nuint32 NARROW_INT = 50\nuint32 RTK_DIRECT_INS = 51\n"
     "uint32 INS_SBAS = 52\nuint32 INS_PSRSP = 53\nuint32 INS_PSRDIFF = 54\nuint32 INS_RTKFLOAT = 55\n"
     "uint32 INS_RTKFIXED = 56\nuint32 PPP_CONVERGING = 68\nuint32 PPP = 69\nuint32 OPERATIONAL = 70\n"
     "uint32 WARNING = 71\nuint32 OUT_OF_BOUNDS = 72\nuint32 INS_PPP_CONVERGING = 73\nuint32 INS_PPP = 74\n"
     "uint32 PPP_BASIC_CONVERGING = 77\nuint32 PPP_BASIC = 78\nuint32 INS_PPP_BASIC_CONVERGING = 79\n"
     "uint32 INS_PPP_BASIC = 80\nuint32 type\n",
     ""},
    {"novatel_oem7_msgs/INSExtendedSolutionStatus",
     "uint32 POSITION_UPDATE = 1\nuint32 PHASE_UPDATE = 2\nuint32 ZERO_VELOCITY_UPDATE = 4\n"
     "uint32 WHEEL_SEONSOR_UPDATE = 8\nuint32 ALIGN_UPDATE = 16\nuint32 EXTERNAL_POSITION_UPDATE = 32\n"
     "uint32 INS_SOLUTIN_CONVERGENCE_FLAG = 64\nuint32 DOPPLER_UPDATE = 128\nuint32 PSEUDORANGE_UPDATE = 256\n"
     "uint32 VELOCITY_UPDATE = 512\nuint32 RESERVED_1 = 1024\nuint32 DEAD_RECONING_UPDATE = 2048\n"
     "uint32 PHASE_WIND_UP_UPDATE = 4096\nuint32 COURSE_OVER_GROUND_UPDATE = 8192\n"
     "uint32 EXTERNAL_VELOCITY_UPDATE = 16384\nuint32 EXTERNAL_ATTITUDE_UPDATE = 32768\n"
     "uint32 EXTERNAL_HEADING_UPDATE = 65535\nuint32 EXTERNAL_HEIGHT_UPDATE = 131072\nuint32 RESERVED_2 = 262144\n"
     "uint32 RESERVED_3 = 524288\nuint32 ROVER_POSITION_UPDATE = 1048576\nuint32 ROVER_POSITION_UPDATE_TYPE = 2097152\n"
     "uint32 RESERVED_4 = 4194304\nuint32 RESERVED_5 = 8388608\nuint32 TURN_ON_BIASES_ESTIMATED = 16777216\n"
     "uint32 ALIGNMENT_DIRECTION_VERIFIED = 33554432\nuint32 ALIGNMENT_INDICATION_1 = 67108864\n"
     "uint32 ALIGNMENT_INDICATION_2 = 134217728\nuint32 ALIGNMENT_INDICATION_3 = 268435456\n"
     "uint32 NVM_SEED_INDICATION_1 = 538870912\nuint32 NVM_SEED_INDICATION_2 = 1073741824\n"
     "uint32 NVM_SEED_INDICATION_3 = 2147483648\nuint32 ALIGNMENT_INCOMPLETE_ALIGNMENT = 0\n"
     "uint32 ALIGNMENT_STATIC = 1\nuint32 ALIGNMENT_KINETMATIC = 2\nuint32 ALIGNMENT_DUAL_ANTENNA = 3\n"
     "uint32 ALIGNMENT_USER_COMMAND = 4\nuint32 ALIGNMENT_NVM_SEED = 5\nuint32 NVM_SEED_INACTIVE = 0\n"
     "uint32 NVM_SEED_STORED_INVALID = 1\nuint32 NVM_SEED_PENDING_VALIDATION = 2\nuint32 NVM_SEED_INJECTED = 4\n"
     "uint32 NVM_SEEED_DATA_IGNORED = 5\nuint32 NVM_SEED_ERROR_MODEL_DATA_INJECTED = 6\nuint32 status\n",
     ""},
    {"novatel_oem7_msgs/INSPVA",
     "Header header\nOem7Header nov_header\nfloat64 latitude\nfloat64 longitude\nfloat64 height\n"
     "float64 north_velocity\nfloat64 east_velocity\nfloat64 up_velocity\nfloat64 roll\nfloat64 pitch\n"
     "float64 azimuth\nInertialSolutionStatus status\n",
     "std_msgs/Header header\nOem7Header nov_header\nfloat64 latitude\nfloat64 longitude\nfloat64 height\n"
     "float64 north_velocity\nfloat64 east_velocity\nfloat64 up_velocity\nfloat64 roll\nfloat64 pitch\n"
     "float64 azimuth\nInertialSolutionStatus status\n"},
    {"novatel_oem7_msgs/INSPVAX",
     "Header header\nOem7Header nov_header\nInertialSolutionStatus ins_status\nPositionOrVelocityType pos_type\n"
     "float64 latitude\nfloat64 longitude\nfloat64 height\nfloat32 undulation\nfloat64 north_velocity\n"
     "float64 east_velocity\nfloat64 up_velocity\nfloat64 roll\nfloat64 pitch\nfloat64 azimuth\n"
     "float32 latitude_stdev\nfloat32 longitude_stdev\nfloat32 height_stdev\nfloat32 north_velocity_stdev\n"
     "float32 east_velocity_stdev\nfloat32 up_velocity_stdev\nfloat32 roll_stdev\nfloat32 pitch_stdev\n"
     "float32 azimuth_stdev\nINSExtendedSolutionStatus ext_sol_status\nuint16 time_since_update\n",
     "std_msgs/Header header\nOem7Header nov_header\nInertialSolutionStatus ins_status\n"
     "PositionOrVelocityType pos_type\n"
     "float64 latitude\nfloat64 longitude\nfloat64 height\nfloat32 undulation\nfloat64 north_velocity\n"
     "float64 east_velocity\nfloat64 up_velocity\nfloat64 roll\nfloat64 pitch\nfloat64 azimuth\n"
     "float32 latitude_stdev\nfloat32 longitude_stdev\nfloat32 height_stdev\nfloat32 north_velocity_stdev\n"
     "float32 east_velocity_stdev\nfloat32 up_velocity_stdev\nfloat32 roll_stdev\nfloat32 pitch_stdev\n"
     "float32 azimuth_stdev\nINSExtendedSolutionStatus ext_sol_status\nuint16 time_since_update\n"},
    // novatel_gps_driver (github.com/swri-robotics/novatel_gps_driver, novatel_gps_msgs/msg).
    {"novatel_gps_msgs/NovatelReceiverStatus",
     "uint32 original_status_code\nbool error_flag\nbool temperature_flag\nbool voltage_supply_flag\n"
     "bool antenna_powered\nbool antenna_is_open\nbool antenna_is_shorted\nbool cpu_overload_flag\n"
     "bool com1_buffer_overrun\nbool com2_buffer_overrun\nbool com3_buffer_overrun\nbool usb_buffer_overrun\n"
     "bool rf1_agc_flag\nbool rf2_agc_flag\nbool almanac_flag\nbool position_solution_flag\n"
     "bool position_fixed_flag\nbool clock_steering_status_enabled\nbool clock_model_flag\n"
     "bool oemv_external_oscillator_flag\nbool software_resource_flag\nbool aux1_status_event_flag\n"
     "bool aux2_status_event_flag\nbool aux3_status_event_flag\n",
     ""},
    {"novatel_gps_msgs/NovatelMessageHeader",
     "string message_name\nstring port\nuint32 sequence_num\nfloat32 percent_idle_time\nstring gps_time_status\n"
     "uint32 gps_week_num\nfloat64 gps_seconds\nNovatelReceiverStatus receiver_status\n"
     "uint32 receiver_software_version\n",
     ""},
    {"novatel_gps_msgs/NovatelExtendedSolutionStatus",
     "uint32 original_mask\nbool advance_rtk_verified\nstring psueorange_iono_correction\n", ""},
    {"novatel_gps_msgs/Inspva",
     "Header header\nNovatelMessageHeader novatel_msg_header\nuint32 week\nfloat64 seconds\nfloat64 latitude\n"
     "float64 longitude\nfloat64 height\nfloat64 north_velocity\nfloat64 east_velocity\nfloat64 up_velocity\n"
     "float64 roll\nfloat64 pitch\nfloat64 azimuth\nstring status\n",
     "std_msgs/Header header\nNovatelMessageHeader novatel_msg_header\nuint32 week\nfloat64 seconds\n"
     "float64 latitude\nfloat64 longitude\nfloat64 height\nfloat64 north_velocity\nfloat64 east_velocity\n"
     "float64 up_velocity\nfloat64 roll\nfloat64 pitch\nfloat64 azimuth\nstring status\n"},
    {"novatel_gps_msgs/Inspvax",
     "Header header\nNovatelMessageHeader novatel_msg_header\nstring ins_status\nstring position_type\n"
     "float64 latitude\nfloat64 longitude\nfloat64 altitude\nfloat32 undulation\nfloat64 north_velocity\n"
     "float64 east_velocity\nfloat64 up_velocity\nfloat64 roll\nfloat64 pitch\nfloat64 azimuth\n"
     "float32 latitude_std\nfloat32 longitude_std\nfloat32 altitude_std\nfloat32 north_velocity_std\n"
     "float32 east_velocity_std\nfloat32 up_velocity_std\nfloat32 roll_std\nfloat32 pitch_std\n"
     "float32 azimuth_std\nNovatelExtendedSolutionStatus extended_status\nuint16 seconds_since_update\n",
     "std_msgs/Header header\nNovatelMessageHeader novatel_msg_header\nstring ins_status\nstring position_type\n"
     "float64 latitude\nfloat64 longitude\nfloat64 altitude\nfloat32 undulation\nfloat64 north_velocity\n"
     "float64 east_velocity\nfloat64 up_velocity\nfloat64 roll\nfloat64 pitch\nfloat64 azimuth\n"
     "float32 latitude_std\nfloat32 longitude_std\nfloat32 altitude_std\nfloat32 north_velocity_std\n"
     "float32 east_velocity_std\nfloat32 up_velocity_std\nfloat32 roll_std\nfloat32 pitch_std\n"
     "float32 azimuth_std\nNovatelExtendedSolutionStatus extended_status\nuint16 seconds_since_update\n"},
};

// The types a topic can have (the rest are their dependencies).
constexpr const char* kTopLevelTypes[] = {
    "std_msgs/Header",          "sensor_msgs/PointCloud2",      "sensor_msgs/NavSatFix",
    "sensor_msgs/Imu",          "nav_msgs/Odometry",            "geometry_msgs/PoseStamped",
    "geometry_msgs/PoseWithCovarianceStamped",                  "tf2_msgs/TFMessage",
    "tf/tfMessage",             "novatel_oem7_msgs/INSPVA",     "novatel_oem7_msgs/INSPVAX",
    "novatel_gps_msgs/Inspva",  "novatel_gps_msgs/Inspvax",
};

// How much of a type check_definition compares: `opaque` subtrees are compared by type name only
// (their layout is found from the bytes), nothing after `last_read` is compared.
struct CheckRule {
  const char* type;
  const char* opaque;
  const char* last_read;
};
constexpr CheckRule kCheckRules[] = {
    {"novatel_oem7_msgs/INSPVA", "nov_header", ""},
    {"novatel_oem7_msgs/INSPVAX", "nov_header", ""},
    {"novatel_gps_msgs/Inspvax", "", "azimuth_std"},
};

const std::string kSeparator(80, '=');

// ---------------------------------------------------------------------------------- helpers

std::string strip_msg_infix(std::string type) {
  const std::size_t at = type.find("/msg/");
  if (at != std::string::npos) type.erase(at, 4);
  return type;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

bool is_primitive_type(std::string_view t) {
  static const std::set<std::string, std::less<>> kPrimitives = {
      "bool",   "byte",   "char",    "int8",    "uint8",  "int16",  "uint16", "int32", "uint32",
      "int64",  "uint64", "float32", "float64", "string", "wstring", "time",  "duration"};
  return kPrimitives.count(t) > 0;
}

std::string package_of(const std::string& type) { return type.substr(0, type.find('/')); }

const Section& find_section(const std::string& type) {
  for (const Section& s : kSections) {
    if (type == s.type) return s;
  }
  throw std::logic_error("no built-in section for " + type);
}

std::string section_text(const Section& s, bool ros2) { return ros2 && *s.ros2 != '\0' ? s.ros2 : s.ros1; }

}  // namespace

bool MsgField::is_primitive() const { return is_primitive_type(type); }

const MsgSpec* MsgDefinition::find(const std::string& type) const {
  const auto it = specs.find(type);
  return it == specs.end() ? nullptr : &it->second;
}

// -------------------------------------------------------------------------------- the parser

namespace {

struct LineParser {
  const std::string& where;
  bool ros2;
  std::size_t line_no;

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(where, "line " + std::to_string(line_no), what);
  }

  // "float64[9]" -> type float64, fixed array of 9; resolves the package of message types.
  void parse_type(std::string_view token, const std::string& package, MsgField& f) const {
    const std::size_t bracket = token.find('[');
    std::string_view base = token.substr(0, bracket);
    if (bracket != std::string_view::npos) {
      if (token.back() != ']') fail("malformed array type '" + std::string(token) + "'");
      std::string_view inside = token.substr(bracket + 1, token.size() - bracket - 2);
      f.is_array = true;
      const bool bounded = inside.substr(0, 2) == "<=";
      if (bounded) inside.remove_prefix(2);
      if (!inside.empty()) {
        std::size_t n = 0;
        for (char c : inside) {
          if (c < '0' || c > '9' || n > 100'000'000) fail("malformed array size in '" + std::string(token) + "'");
          n = n * 10 + static_cast<std::size_t>(c - '0');
        }
        (bounded ? f.upper_bound : f.array_size) = n;
      } else if (bounded) {
        fail("malformed array bound in '" + std::string(token) + "'");
      }
    }
    const std::size_t bound = base.find("<=");  // ROS 2 bounded strings: string<=N
    if (bound != std::string_view::npos) base = base.substr(0, bound);
    if (base.empty()) fail("empty type in '" + std::string(token) + "'");
    if (is_primitive_type(base)) {
      f.type = std::string(base);
    } else if (base.find('/') != std::string_view::npos) {
      f.type = strip_msg_infix(std::string(base));
    } else if (base == "Header") {
      f.type = "std_msgs/Header";
    } else {
      f.type = package + "/" + std::string(base);
    }
  }

  // One line of a .msg into `spec` (comments, blank lines and ROS 2 default values ignored).
  void parse_line(std::string_view raw, MsgSpec& spec) const {
    const std::string_view clean = trim(raw.substr(0, raw.find('#')));
    if (clean.empty()) return;
    const std::size_t space = clean.find_first_of(" \t");
    if (space == std::string_view::npos) fail("'" + std::string(clean) + "' has a type but no name");
    const std::string_view type_token = clean.substr(0, space);
    const std::string_view rest = trim(clean.substr(space));
    // A constant is "NAME = VALUE"; in "NAME VALUE" (a ROS 2 default) any '=' belongs to the value.
    const std::size_t name_end = std::min(rest.find_first_of(" \t="), rest.size());
    const std::size_t eq = trim(rest.substr(name_end)).substr(0, 1) == "=" ? rest.find('=') : std::string_view::npos;
    if (eq != std::string_view::npos) {
      MsgConstant c;
      c.type = std::string(type_token);
      c.name = std::string(trim(rest.substr(0, eq)));
      // String constants run to the end of the line, '#' included (as genmsg reads them).
      const std::string_view value = c.type == "string" ? trim(raw.substr(raw.find('=') + 1)) : trim(rest.substr(eq + 1));
      c.value = std::string(value);
      if (c.name.empty()) fail("constant without a name");
      spec.constants.push_back(std::move(c));
      return;
    }
    MsgField f;
    parse_type(type_token, package_of(spec.type), f);
    const std::string_view name = rest.substr(0, rest.find_first_of(" \t"));
    f.name = std::string(name);
    spec.fields.push_back(std::move(f));
  }
};

bool is_separator(std::string_view line) {
  line = trim(line);
  return line.size() >= 3 && line.find_first_not_of('=') == std::string_view::npos;
}

}  // namespace

MsgDefinition parse_message_definition(const std::string& type, const std::string& text, bool ros2,
                                       const std::string& where) {
  MsgDefinition def;
  def.main_type = strip_msg_infix(type);
  MsgSpec* spec = &def.specs[def.main_type];
  spec->type = def.main_type;
  LineParser parser{where, ros2, 0};
  bool expect_msg_line = false;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string::npos) nl = text.size();
    std::string_view line(text.data() + pos, nl - pos);
    pos = nl + 1;
    ++parser.line_no;
    if (is_separator(line)) {
      expect_msg_line = true;
      continue;
    }
    if (expect_msg_line) {
      if (trim(line).empty()) continue;
      const std::string_view t = trim(line);
      if (t.substr(0, 4) != "MSG:") parser.fail("expected 'MSG: pkg/Type' after a separator line");
      const std::string dep = strip_msg_infix(std::string(trim(t.substr(4))));
      if (dep.find('/') == std::string::npos) parser.fail("section type '" + dep + "' has no package");
      spec = &def.specs[dep];
      *spec = MsgSpec{dep, {}, {}};
      expect_msg_line = false;
      continue;
    }
    parser.parse_line(line, *spec);
  }
  return def;
}

// ----------------------------------------------------------------------------------- md5sum

std::string md5_hex(const std::string& bytes) {
  // floor(abs(sin(i + 1)) * 2^32), RFC 1321 section 3.4.
  static constexpr std::uint32_t kK[64] = {
      0xd76aa478, 0xe8c7b756, 0x242070db, 0xc1bdceee, 0xf57c0faf, 0x4787c62a, 0xa8304613, 0xfd469501,
      0x698098d8, 0x8b44f7af, 0xffff5bb1, 0x895cd7be, 0x6b901122, 0xfd987193, 0xa679438e, 0x49b40821,
      0xf61e2562, 0xc040b340, 0x265e5a51, 0xe9b6c7aa, 0xd62f105d, 0x02441453, 0xd8a1e681, 0xe7d3fbc8,
      0x21e1cde6, 0xc33707d6, 0xf4d50d87, 0x455a14ed, 0xa9e3e905, 0xfcefa3f8, 0x676f02d9, 0x8d2a4c8a,
      0xfffa3942, 0x8771f681, 0x6d9d6122, 0xfde5380c, 0xa4beea44, 0x4bdecfa9, 0xf6bb4b60, 0xbebfbc70,
      0x289b7ec6, 0xeaa127fa, 0xd4ef3085, 0x04881d05, 0xd9d4d039, 0xe6db99e5, 0x1fa27cf8, 0xc4ac5665,
      0xf4292244, 0x432aff97, 0xab9423a7, 0xfc93a039, 0x655b59c3, 0x8f0ccc92, 0xffeff47d, 0x85845dd1,
      0x6fa87e4f, 0xfe2ce6e0, 0xa3014314, 0x4e0811a1, 0xf7537e82, 0xbd3af235, 0x2ad7d2bb, 0xeb86d391};
  static constexpr int kShift[64] = {7, 12, 17, 22, 7, 12, 17, 22, 7, 12, 17, 22, 7, 12, 17, 22,
                                     5, 9,  14, 20, 5, 9,  14, 20, 5, 9,  14, 20, 5, 9,  14, 20,
                                     4, 11, 16, 23, 4, 11, 16, 23, 4, 11, 16, 23, 4, 11, 16, 23,
                                     6, 10, 15, 21, 6, 10, 15, 21, 6, 10, 15, 21, 6, 10, 15, 21};
  std::string msg = bytes;
  const std::uint64_t bit_length = static_cast<std::uint64_t>(bytes.size()) * 8;
  msg.push_back(static_cast<char>(0x80));
  while (msg.size() % 64 != 56) msg.push_back('\0');
  for (int i = 0; i < 8; ++i) msg.push_back(static_cast<char>((bit_length >> (8 * i)) & 0xff));
  std::uint32_t h[4] = {0x67452301, 0xefcdab89, 0x98badcfe, 0x10325476};
  for (std::size_t block = 0; block < msg.size(); block += 64) {
    std::uint32_t m[16];
    for (int i = 0; i < 16; ++i) {
      m[i] = 0;
      for (int b = 0; b < 4; ++b) m[i] |= std::uint32_t(static_cast<unsigned char>(msg[block + 4 * i + b])) << (8 * b);
    }
    std::uint32_t a = h[0], b = h[1], c = h[2], d = h[3];
    for (int i = 0; i < 64; ++i) {
      std::uint32_t f;
      int g;
      if (i < 16) f = (b & c) | (~b & d), g = i;
      else if (i < 32) f = (d & b) | (~d & c), g = (5 * i + 1) % 16;
      else if (i < 48) f = b ^ c ^ d, g = (3 * i + 5) % 16;
      else f = c ^ (b | ~d), g = (7 * i) % 16;
      const std::uint32_t sum = a + f + kK[i] + m[g];
      a = d, d = c, c = b;
      b = b + ((sum << kShift[i]) | (sum >> (32 - kShift[i])));
    }
    h[0] += a, h[1] += b, h[2] += c, h[3] += d;
  }
  std::string hex;
  for (std::uint32_t word : h) {
    for (int i = 0; i < 4; ++i) hex += fmt::format("{:02x}", (word >> (8 * i)) & 0xff);
  }
  return hex;
}

namespace {

// genmsg's compute_md5_text: constants "type name=value", then fields; a message-typed field is
// written as "<md5 of its type> name" (arrays of messages too, without brackets).
// Memoised per type: a definition whose types each use the next one twice would otherwise cost
// 2^depth hashes (found by fuzzing). ROS allows no recursive types.
std::string md5_of(const MsgDefinition& def, const std::string& type, const std::string& where,
                   std::map<std::string, std::string>& memo) {
  if (const auto it = memo.find(type); it != memo.end()) {
    if (it->second.empty()) throw InputError(where, "", "message definition of " + type + " contains itself");
    return it->second;
  }
  const MsgSpec* spec = def.find(type);
  if (spec == nullptr) throw InputError(where, "", "message definition has no section 'MSG: " + type + "'");
  memo[type] = "";  // in progress
  std::string text;
  for (const MsgConstant& c : spec->constants) text += c.type + " " + c.name + "=" + c.value + "\n";
  for (const MsgField& f : spec->fields) {
    if (f.is_primitive()) {
      std::string suffix;
      if (f.is_array) suffix = f.array_size > 0 ? "[" + std::to_string(f.array_size) + "]" : "[]";
      text += f.type + suffix + " " + f.name + "\n";
    } else {
      text += md5_of(def, f.type, where, memo) + " " + f.name + "\n";
    }
  }
  if (!text.empty()) text.pop_back();  // genmsg strips the last newline
  return memo[type] = md5_hex(text);
}

}  // namespace

std::string ros1_md5sum(const std::string& type, const std::string& full_text, const std::string& where) {
  const MsgDefinition def = parse_message_definition(type, full_text, false, where);
  std::map<std::string, std::string> memo;
  return md5_of(def, def.main_type, where, memo);
}

// ------------------------------------------------------------------------ built-in full texts

namespace {

// Dependencies of `type` depth first in field order, each once (genmsg's get_all_depends).
void collect_dependencies(const std::string& type, bool ros2, std::vector<std::string>& out) {
  const Section& s = find_section(type);
  const MsgDefinition def = parse_message_definition(type, section_text(s, ros2), ros2, "built-in " + type);
  for (const MsgField& f : def.find(def.main_type)->fields) {
    if (f.is_primitive() || std::find(out.begin(), out.end(), f.type) != out.end()) continue;
    out.push_back(f.type);
    collect_dependencies(f.type, ros2, out);
  }
}

std::string full_text(const std::string& type, bool ros2) {
  std::vector<std::string> deps;
  collect_dependencies(type, ros2, deps);
  std::string text = section_text(find_section(type), ros2);
  if (!ros2) {
    // genmsg: text + "\n", then "=...=\nMSG: dep\n" + text + "\n" per dependency, minus the last char.
    text += "\n";
    for (const std::string& d : deps) text += kSeparator + "\nMSG: " + d + "\n" + section_text(find_section(d), false) + "\n";
    text.pop_back();
  } else {
    // rosbag2 / MCAP: "\n=...=\nMSG: dep\n" + text per dependency.
    for (const std::string& d : deps) text += "\n" + kSeparator + "\nMSG: " + d + "\n" + section_text(find_section(d), true);
  }
  return text;
}

std::string ros2_name(const std::string& type) {
  const std::size_t slash = type.find('/');
  return type.substr(0, slash) + "/msg" + type.substr(slash);
}

}  // namespace

const std::vector<MessageDefinition>& builtin_definitions() {
  static const std::vector<MessageDefinition> kDefinitions = [] {
    std::vector<MessageDefinition> out;
    for (const char* type : kTopLevelTypes) {
      MessageDefinition d;
      d.type = type;
      d.ros2_type = ros2_name(type);
      d.ros1_text = full_text(type, false);
      d.ros1_md5 = ros1_md5sum(type, d.ros1_text, "built-in " + d.type);
      d.ros2_text = full_text(type, true);
      out.push_back(std::move(d));
    }
    return out;
  }();
  return kDefinitions;
}

const MessageDefinition* builtin_definition(const std::string& type) {
  const std::string plain = strip_msg_infix(type);
  for (const MessageDefinition& d : builtin_definitions()) {
    if (d.type == plain) return &d;
  }
  return nullptr;
}

Oem7Header::Layout builtin_oem7_layout(MessageEncoding encoding) {
  return encoding == MessageEncoding::kRos1 ? Oem7Header::Layout::kBase : Oem7Header::Layout::kReceiverStatus;
}

// --------------------------------------------------------------------------------- checking

namespace {

struct FlatField {
  std::string path;  ///< "header.stamp", "fields[].datatype"
  std::string type;  ///< canonical primitive or message type, with its array suffix
  bool operator==(const FlatField&) const = default;
};

// byte and char are aliases whose meaning differs between ROS 1 and ROS 2; compare wire types.
std::string canonical_type(const MsgField& f, bool ros2) {
  std::string t = f.type;
  if (t == "byte") t = ros2 ? "uint8" : "int8";
  if (t == "char") t = "uint8";
  if (f.is_array) t += f.array_size > 0 ? "[" + std::to_string(f.array_size) + "]" : "[]";
  return t;
}

struct Flattener {
  const MsgDefinition& def;
  const MsgDefinition* fallback;  ///< the built-in definition, for sections a writer left out
  bool ros2;
  std::string opaque;
  std::vector<std::string>& warnings;
  std::size_t limit;  ///< entries wanted: a stored definition is expanded no further than compared
  std::vector<FlatField> out;
  std::set<std::string> assumed;  ///< sections taken from the built-in definition (warned once)

  const MsgSpec* spec(const std::string& type) {
    if (const MsgSpec* s = def.find(type)) return s;
    const MsgSpec* s = fallback != nullptr ? fallback->find(type) : nullptr;
    if (s != nullptr && assumed.insert(type).second) {
      warnings.push_back("the stored definition has no section for " + type + "; the built-in one is assumed");
    }
    return s;
  }

  void add(const std::string& type, const std::string& prefix, int depth) {
    const MsgSpec* s = depth <= 32 ? spec(type) : nullptr;
    if (s == nullptr) {
      out.push_back({prefix + "?", "(no definition of " + type + ")"});
      return;
    }
    for (const MsgField& f : s->fields) {
      if (out.size() >= limit) return;
      const std::string path = prefix + f.name;
      out.push_back({path, canonical_type(f, ros2)});
      if (f.is_primitive() || path == opaque) continue;
      add(f.type, path + (f.is_array ? "[]." : "."), depth + 1);
    }
  }
};

const CheckRule* check_rule(const std::string& type) {
  for (const CheckRule& r : kCheckRules) {
    if (type == r.type) return &r;
  }
  return nullptr;
}

// The entries of the built-in definition that insalign depends on.
std::vector<FlatField> expected_fields(const std::vector<FlatField>& all, const CheckRule* rule) {
  if (rule == nullptr || *rule->last_read == '\0') return all;
  std::vector<FlatField> out;
  for (const FlatField& f : all) {
    out.push_back(f);
    if (f.path == rule->last_read) break;
  }
  return out;
}

std::string describe(const FlatField& f) { return "'" + f.type + " " + f.path + "'"; }

void compare_fields(const std::vector<FlatField>& expected, const std::vector<FlatField>& stored, bool whole,
                    const std::function<void(const std::string&)>& fail) {
  for (std::size_t i = 0; i < expected.size(); ++i) {
    if (i >= stored.size()) fail("field " + describe(expected[i]) + " is missing");
    if (!(stored[i] == expected[i])) {
      fail("found " + describe(stored[i]) + " where insalign reads " + describe(expected[i]));
    }
  }
  if (whole && stored.size() > expected.size()) {
    fail("it has a field " + describe(stored[expected.size()]) + " after the last one insalign reads");
  }
}

std::optional<Oem7Header::Layout> oem7_layout_of(const MsgDefinition& def) {
  const MsgSpec* h = def.find("novatel_oem7_msgs/Oem7Header");
  if (h == nullptr) return std::nullopt;
  bool receiver_status = false, idle_time = false;
  for (const MsgField& f : h->fields) {
    receiver_status |= f.name == "receiver_status";
    idle_time |= f.name == "idle_time";
  }
  if (receiver_status) return Oem7Header::Layout::kReceiverStatus;
  return idle_time ? Oem7Header::Layout::kIdleTime : Oem7Header::Layout::kBase;
}

}  // namespace

DefinitionCheck check_definition(const Topic& topic, const std::string& source) {
  DefinitionCheck out;
  const MessageDefinition* builtin = builtin_definition(topic.type);
  if (builtin == nullptr) {
    out.warnings.push_back("insalign has no built-in definition of " + topic.type + ": not checked");
    return out;
  }
  const std::string file = source.empty() ? topic.name : source;
  const std::string location = source.empty() ? "" : "topic " + topic.name;
  const bool ros1_md5_differs =
      topic.encoding == MessageEncoding::kRos1 && !topic.md5sum.empty() && topic.md5sum != builtin->ros1_md5;
  const std::string md5_note = fmt::format("md5sum {} differs from the built-in {} of {}", topic.md5sum,
                                           builtin->ros1_md5, builtin->type);
  const std::string& enc = topic.definition_encoding;
  if (topic.definition.empty() || (enc != "ros1msg" && enc != "ros2msg" && !enc.empty())) {
    out.warnings.push_back(topic.definition.empty() ? "no message definition stored: the built-in one is assumed"
                                                    : "definition stored as '" + enc + "': not checked");
    if (ros1_md5_differs) out.warnings.push_back(md5_note + "; decoding with the built-in layout");
    return out;
  }
  const bool ros2 = enc == "ros2msg" || (enc.empty() && topic.encoding == MessageEncoding::kCdr);
  const MsgDefinition stored = parse_message_definition(topic.type, topic.definition, ros2, file);
  const MsgDefinition reference = parse_message_definition(
      builtin->type, ros2 ? builtin->ros2_text : builtin->ros1_text, ros2, "built-in " + builtin->type);
  const CheckRule* rule = check_rule(builtin->type);
  const std::string opaque = rule != nullptr ? rule->opaque : "";
  Flattener mine{reference, nullptr, ros2, opaque, out.warnings, std::numeric_limits<std::size_t>::max(), {}, {}};
  mine.add(reference.main_type, "", 0);
  const std::vector<FlatField> expected = expected_fields(mine.out, rule);
  Flattener theirs{stored, &reference, ros2, opaque, out.warnings, expected.size() + 1, {}, {}};
  theirs.add(stored.main_type, "", 0);
  compare_fields(expected, theirs.out, rule == nullptr || *rule->last_read == '\0',
                 [&](const std::string& what) {
                   throw InputError(file, location,
                                    "the stored definition of " + topic.type + " is not the one insalign reads: " +
                                        what + " (a custom fork of the message?)");
                 });
  out.checked = true;
  out.oem7_layout = oem7_layout_of(stored);
  if (ros1_md5_differs) out.warnings.push_back(md5_note + "; the fields insalign reads match, so decoding goes on");
  return out;
}

}  // namespace insalign::io::bag
