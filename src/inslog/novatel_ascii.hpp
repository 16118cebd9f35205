// NovAtel OEM7 ASCII logs as a receiver (or NovAtel Connect) writes them: one record per line,
// `#NAME,port,seq,idle,time_status,week,seconds,rx_status,reserved,sw;body*crc32` (long header) or
// `%NAME,week,seconds;body*crc32` (short header). Read: #INSPVAA and %INSPVASA (ellipsoidal height,
// body time) and #INSPVAXA (height above mean sea level + undulation, header time, position
// standard deviations and position type). Every other record is counted and ignored.
//
// CRC: NovAtel's 32-bit CRC (reflected polynomial 0xEDB88320, initial value 0, no final XOR) over
// the bytes after '#'/'%' up to '*' exclusive, checked against the 8 hex digits after '*'
// (verified on the example records of NovAtel's OEM7 documentation, tests/novatel_ascii_test.cpp).
// A record with a bad CRC or cut short is skipped and counted; more than max_bad_fraction of the INS
// records or more than max_bad_records is an InputError (the file is corrupt, not a few glitches).
//
// INS status -> GnssSolution (InsRecord::solution):
//   INS_SOLUTION_GOOD              -> from the INSPVAX position type (INS_RTKFIXED -> kRtkFixed,
//                                     INS_RTKFLOAT -> kRtkFloat, INS_PSRDIFF / INS_SBAS / INS_PPP* /
//                                     INS_OMNISTAR* -> kDifferential, INS_PSRSP -> kSingle, NONE ->
//                                     kInsOnly); kUnknown for INSPVA, which states no position type
//   INS_SOLUTION_FREE              -> kInsOnly (navigating without GNSS)
//   INS_ALIGNMENT_COMPLETE,
//   INS_HIGH_VARIANCE              -> kInvalid (navigating, but not within specification yet)
//   INS_INACTIVE, INS_ALIGNING, INS_DETERMINING_ORIENTATION, INS_WAITING_*, INS_INITIALIZING_BIASES,
//   INS_MOTION_DETECT, other       -> record skipped and counted (its numbers are placeholders:
//                                     receivers print latitude -90 and height -6356752 m there)
// A header time status UNKNOWN skips the record too (its time is not GPS time).
//
// When a log holds both INSPVA(S) and INSPVAX, the more frequent one gives the poses; INSPVAX, when
// it is the rarer, still gives solution and standard deviations to the INSPVA records that follow it
// within 1.5 s (NovAtel recommends INSPVAS at a high rate and the extended log at 1 Hz).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "inslog/ins_track.hpp"

namespace insalign::io {

struct NovatelReadOptions {
  double max_bad_fraction = 0.05;     ///< bad-CRC / truncated INS records allowed, of all INS records
  std::size_t max_bad_records = 100;  ///< and at most this many
};

/// The GnssSolution of a NovAtel position type name (INSPVAX's "INS_RTKFIXED", BESTPOS's
/// "NARROW_INT", "PSRDIFF", "SINGLE", ...), as in the table above; kUnknown for names it does not know.
GnssSolution novatel_pos_type_solution(std::string_view pos_type);

/// NovAtel's CRC-32 of `bytes` (the text between '#'/'%' and '*').
std::uint32_t novatel_crc32(std::string_view bytes);

/// Reads the log into a geodetic InsTrack (t_s UNIX, WGS-84 ellipsoidal heights, R_world_ins =
/// R_enu_ins_novatel at each fix). Throws InputError(file, "line N", what).
InsTrack read_novatel_ascii(const std::filesystem::path& path, const NovatelReadOptions& options = {});
InsTrack parse_novatel_ascii(std::string_view text, const std::string& file_for_errors,
                             const NovatelReadOptions& options = {});

/// True if `text` (a file's first bytes) holds a NovAtel ASCII record start ('#' or '%', an
/// upper-case log name ending in 'A', then ','): detection for read_ins_log.
bool looks_like_novatel_ascii(std::string_view text);

}  // namespace insalign::io
