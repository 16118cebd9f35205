// Every attitude convention insalign reads, in one place: each function returns R_enu_ins, the
// orientation of the source's `ins` body frame in the local ENU frame (x east, y north, z up) at
// the vehicle's position. Angles in degrees as the sources write them. Getting one of these wrong
// silently rotates the result, so each is tested by driving north, east, south and west.
#pragma once

#include "core/geometry.hpp"

namespace insalign::io {

/// NovAtel SPAN (INSPVA, INSPVAX, INSPVAS; novatel_oem7_msgs and novatel_gps_msgs): vehicle frame
/// x right, y forward, z up; roll about y, pitch about x, azimuth clockwise from north about -z:
/// R_enu_ins = Rz(-azimuth) Rx(pitch) Ry(roll) (CONVENTIONS.md).
Mat3 R_enu_ins_novatel(double roll_deg, double pitch_deg, double azimuth_deg);

/// Aerospace NED angles (POSPac SBET, most post-processed exports): body x forward, y right,
/// z down; R_ned_body = Rz(heading) Ry(pitch) Rx(roll), heading clockwise from north.
Mat3 R_enu_ins_ned(double roll_deg, double pitch_deg, double heading_deg);

/// ENU yaw angles (KITTI oxts, ROS REP-103 sources): body x forward, y left, z up;
/// R_enu_ins = Rz(yaw) Ry(pitch) Rx(roll), yaw counter-clockwise from east.
Mat3 R_enu_ins_enu(double roll_deg, double pitch_deg, double yaw_deg);

/// R_enu_ned: maps NED vectors into ENU (swap x and y, negate z).
Mat3 R_enu_ned();

}  // namespace insalign::io
