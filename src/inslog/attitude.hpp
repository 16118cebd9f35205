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

/// POSPac SBET: NED angles whose heading is the platform heading in the wander-azimuth frame; the
/// true heading is platform heading - wander angle (Applanix's definition), then as R_enu_ins_ned.
Mat3 R_enu_ins_sbet(double roll_deg, double pitch_deg, double platform_heading_deg, double wander_deg);

/// The angles (deg) each convention above writes for R_enu_ins, for the writers: applying the
/// convention's function to them gives R_enu_ins back. `heading_deg` is the convention's third
/// angle: NovAtel azimuth and NED heading in [0, 360) clockwise from north, ENU yaw in (-180, 180]
/// counter-clockwise from east. Pitch in [-90, 90]; at +-90 deg the split between roll and heading
/// is arbitrary (the rotation is still reproduced).
struct AttitudeDeg {
  double roll_deg = 0.0, pitch_deg = 0.0, heading_deg = 0.0;
};
AttitudeDeg novatel_angles(const Mat3& R_enu_ins);
AttitudeDeg ned_angles(const Mat3& R_enu_ins);
AttitudeDeg enu_angles(const Mat3& R_enu_ins);

}  // namespace insalign::io
