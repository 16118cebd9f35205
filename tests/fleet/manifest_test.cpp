// The manifest parser: RFC 4180 quoting, and every malformed manifest named by line and column.
#include "fleet/manifest.hpp"

#include <gtest/gtest.h>

#include "core/errors.hpp"

namespace insalign::fleet {
namespace {

const char* kHeader = "car,date,kind,input,extrinsic,options\n";

std::string error_of(const std::string& text) {
  try {
    parse_manifest(text, "m.csv");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Manifest, ReadsQuotedFieldsAndColumnsInAnyOrder) {
  const std::string text =
      "kind,car,date,options,input,extrinsic\r\n"
      "calibrate,car-1,2026-03-01,\"--fiducials \"\"f 1.txt\"\"\",\"--lidar-dir d/lidar --poses d/poses.txt\",\r\n"
      "check,car.2,2026-03-02T08:30:00Z,,\"--bag \"\"a,b.mcap\"\"\",inst/extrinsic.json\r\n"
      "\r\n";
  const Manifest m = parse_manifest(text, "m.csv");
  ASSERT_EQ(m.rows.size(), 2u);
  EXPECT_EQ(m.rows[0].id(), "car-1/2026-03-01-calibrate");
  EXPECT_EQ(m.rows[0].options, "--fiducials \"f 1.txt\"");
  EXPECT_EQ(m.rows[0].line, 2);
  EXPECT_EQ(m.rows[1].id(), "car.2/2026-03-02T08:30:00Z-check");
  EXPECT_EQ(m.rows[1].input, "--bag \"a,b.mcap\"");
  EXPECT_EQ(m.rows[1].extrinsic, "inst/extrinsic.json");
  EXPECT_EQ(split_words(m.rows[1].input, "m.csv", ""), (std::vector<std::string>{"--bag", "a,b.mcap"}));
  EXPECT_EQ(split_words(m.rows[0].options, "m.csv", ""), (std::vector<std::string>{"--fiducials", "f 1.txt"}));
}

TEST(Manifest, QuotedFieldMayHoldALineBreak) {
  const Manifest m = parse_manifest(std::string(kHeader) + "a,2026-01-01,calibrate,\"--lidar-dir x\n--poses p\",,\n"
                                                           "b,2026-01-01,calibrate,--lidar-dir y --poses q,,\n",
                                    "m.csv");
  ASSERT_EQ(m.rows.size(), 2u);
  EXPECT_EQ(split_words(m.rows[0].input, "", "").size(), 4u);
  EXPECT_EQ(m.rows[1].line, 4);  // the line break inside the quotes counts
}

TEST(Manifest, MalformedManifestsNameLineAndColumn) {
  const std::string h = kHeader;
  EXPECT_NE(error_of(h + "a,2026-01-01,calibrate,--lidar-dir x,,\na,2026-01-01,calibrate,--lidar-dir y,,\n")
                .find("m.csv:line 3, column 1: duplicate id a/2026-01-01-calibrate (lines 2 and 3)"),
            std::string::npos);
  EXPECT_NE(error_of(h + "a,2026-01-01,calibrat,--lidar-dir x,,\n").find("line 2, column 14: unknown kind \"calibrat\""),
            std::string::npos);
  EXPECT_NE(error_of("car,date,kind,input,options\n").find("missing column \"extrinsic\""), std::string::npos);
  EXPECT_NE(error_of("car,date,kind,input,extrinsic,options,notes\n").find("line 1, column 39: unknown column \"notes\""),
            std::string::npos);
  EXPECT_NE(error_of(h + "a,2026-01-01,calibrate,\"--lidar-dir x,,\n").find("line 2, column 24: the quoted field is not closed"),
            std::string::npos);
  EXPECT_NE(error_of(h + "a,2026-01-01,calibrate,--lidar-dir \"x\",,\n").find("line 2, column 36: a quote inside an unquoted field"),
            std::string::npos);
  EXPECT_NE(error_of(h + "a,2026-01-01,calibrate,\"x\"y,,\n").find("line 2, column 27: text after the closing quote"),
            std::string::npos);
  EXPECT_NE(error_of(h + "a,2026-01-01,calibrate,--lidar-dir x,\n").find("line 2, column 38: the row has 5 fields, the header 6"),
            std::string::npos);
  EXPECT_NE(error_of(h + "a,01/02/2026,calibrate,--lidar-dir x,,\n").find("line 2, column 3: date \"01/02/2026\" is not ISO 8601"),
            std::string::npos);
  EXPECT_NE(error_of(h + "../a,2026-01-01,calibrate,--lidar-dir x,,\n").find("line 2, column 1: car \"../a\" is not a folder name"),
            std::string::npos);
  EXPECT_NE(error_of(h + "a,2026-01-01,check,--lidar-dir x,,\n").find("line 2, column 34: a check row needs the installed extrinsic"),
            std::string::npos);
  EXPECT_NE(error_of(h + "a,2026-01-01,calibrate,--lidar-dir x,,--out y\n").find("options must not hold --out"), std::string::npos);
  EXPECT_NE(error_of(h + "a,2026-01-01,calibrate,--lidar-dir 'x,,\n").find("unterminated single quote"), std::string::npos);
  EXPECT_NE(error_of("").find("empty manifest"), std::string::npos);
  EXPECT_NE(error_of(h + "a,2026-13-01,calibrate,--lidar-dir x,,\n").find("is not ISO 8601"), std::string::npos);
}

}  // namespace
}  // namespace insalign::fleet
