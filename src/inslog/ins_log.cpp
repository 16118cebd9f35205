#include "inslog/ins_log.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>

#include "core/errors.hpp"
#include "inslog/kitti.hpp"
#include "inslog/sbet.hpp"

namespace insalign::io {
namespace {

constexpr std::size_t kDetectBytes = 64 * 1024;

std::string head_of(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "", "cannot open");
  std::string head(kDetectBytes, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return head;
}

// Text has no NUL and almost no control characters besides tab, CR, LF.
bool is_binary(std::string_view bytes) {
  std::size_t control = 0;
  for (const char ch : bytes) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == 0) return true;
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\r' && c != '\f') ++control;
  }
  return control * 100 > bytes.size();
}

std::filesystem::path oxts_dir_of(const std::filesystem::path& path) {
  return is_kitti_oxts_dir(path) ? path : path / "oxts";
}

}  // namespace

const char* ins_log_format_name(InsLogFormat format) {
  switch (format) {
    case InsLogFormat::kNovatelAscii: return "novatel";
    case InsLogFormat::kSbet: return "sbet";
    case InsLogFormat::kTextExport: return "csv";
    case InsLogFormat::kKittiOxts: return "kitti";
  }
  return "?";
}

std::optional<InsLogFormat> parse_ins_log_format(std::string_view name) {
  for (const auto f : {InsLogFormat::kNovatelAscii, InsLogFormat::kSbet, InsLogFormat::kTextExport, InsLogFormat::kKittiOxts}) {
    if (name == ins_log_format_name(f)) return f;
  }
  return std::nullopt;
}

std::optional<InsLogFormat> detect_ins_log(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path.string(), "", "file not found");
  if (std::filesystem::is_directory(path, ec)) {
    if (is_kitti_oxts_dir(path) || is_kitti_oxts_dir(path / "oxts")) return InsLogFormat::kKittiOxts;
    return std::nullopt;
  }
  const std::string head = head_of(path);
  if (looks_like_novatel_ascii(head)) return InsLogFormat::kNovatelAscii;
  if (is_binary(head)) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (looks_like_sbet(head) || ext == ".out" || ext == ".sbet") return InsLogFormat::kSbet;
    // A binary NovAtel log starts with its sync bytes AA 44 12 (13: short header): read_novatel_ascii
    // then says to convert it.
    if (head.rfind("\xAA\x44\x12", 0) == 0 || head.rfind("\xAA\x44\x13", 0) == 0) return InsLogFormat::kNovatelAscii;
    return std::nullopt;
  }
  if (text_export_header(head)) return InsLogFormat::kTextExport;
  return std::nullopt;
}

InsTrack read_ins_log(const std::filesystem::path& path, InsLogFormat format, const InsLogOptions& options) {
  switch (format) {
    case InsLogFormat::kNovatelAscii: return read_novatel_ascii(path, options.novatel);
    case InsLogFormat::kSbet: return read_sbet(path, options.lidar_time_hint_unix_s);
    case InsLogFormat::kTextExport: return read_text_export(path, options.columns, options.lidar_time_hint_unix_s);
    case InsLogFormat::kKittiOxts: return read_kitti_oxts(oxts_dir_of(path));
  }
  throw InputError(path.string(), "", "unknown INS log format");
}

}  // namespace insalign::io
