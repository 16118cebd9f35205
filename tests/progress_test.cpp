#include "cli/progress.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace insalign::cli {
namespace {

/// Everything a ProgressBar wrote to a temporary file (a log, not a terminal unless told).
struct Captured {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file{std::tmpfile(), &std::fclose};
  std::string text() {
    std::fflush(file.get());
    std::rewind(file.get());
    std::string s;
    for (int c; (c = std::fgetc(file.get())) != EOF;) s.push_back(static_cast<char>(c));
    return s;
  }
};

int count_lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

TEST(Progress, DurationsReadLikeAClock) {
  EXPECT_EQ(format_duration(7.2), "0:07");
  EXPECT_EQ(format_duration(65), "1:05");
  EXPECT_EQ(format_duration(3723), "1:02:03");
  EXPECT_EQ(format_duration(-1), "?");
}

TEST(Progress, BarShowsFractionAndAnEtaOnlyOnceItMeansSomething) {
  const std::string half = ProgressBar::bar_line("rough", 0.5, 10.0, 10);
  EXPECT_NE(half.find("[#####-----]"), std::string::npos) << half;
  EXPECT_NE(half.find(" 50%"), std::string::npos) << half;
  EXPECT_NE(half.find("ETA 0:10"), std::string::npos) << half;
  EXPECT_EQ(ProgressBar::bar_line("rough", 0.01, 1.0, 10).find("ETA"), std::string::npos);
  EXPECT_EQ(ProgressBar::bar_line("rough", 1.0, 1.0, 10).find("ETA"), std::string::npos);
  EXPECT_NE(ProgressBar::bar_line("rough", 7.0, 1.0, 10).find("100%"), std::string::npos);  // clamped
}

TEST(Progress, LogGetsOneLinePerFinishedStep) {
  Captured out;
  {
    ProgressBar bar(Verbosity::kNormal, out.file.get(), false);
    bar.update("rough", 0.2);
    bar.update("rough", 0.9);
    bar.update("refine", 0.5);  // a new step finishes the previous one
    bar.log("a message");
    bar.detail("not shown without --verbose");
  }  // the destructor finishes the last step
  const std::string text = out.text();
  EXPECT_EQ(count_lines(text), 3) << text;
  EXPECT_NE(text.find("rough      done in"), std::string::npos) << text;
  EXPECT_NE(text.find("refine     done in"), std::string::npos) << text;
  EXPECT_EQ(text.find("not shown"), std::string::npos);
  EXPECT_EQ(text.find('\r'), std::string::npos) << "no redraws in a log";
}

TEST(Progress, LongStepInALogGetsALineAtMostEveryIntervalAndTenth) {
  Captured out;
  {
    ProgressBar bar(Verbosity::kNormal, out.file.get(), false);
    bar.set_log_interval(std::chrono::milliseconds(20));
    for (int i = 1; i <= 100; ++i) {
      bar.update("render", i / 100.0);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));  // 0.5 s in all
    }
  }
  const std::string text = out.text();
  const int progress_lines = count_lines(text) - 1;  // the last line is "done"
  EXPECT_GE(progress_lines, 2) << text;  // 25 intervals passed
  EXPECT_LE(progress_lines, 9) << text;  // but never more than one per tenth
  EXPECT_NE(text.find("render     ["), std::string::npos) << text;
  EXPECT_NE(text.find("render     done in"), std::string::npos) << text;
  EXPECT_EQ(text.find('\r'), std::string::npos) << "no redraws in a log";
}

TEST(Progress, VerboseLogGetsALinePerTenthAndDetails) {
  Captured out;
  {
    ProgressBar bar(Verbosity::kVerbose, out.file.get(), false);
    for (int i = 1; i <= 100; ++i) bar.update("refine", i / 100.0);
    bar.detail("detail line");
  }
  const std::string text = out.text();
  EXPECT_EQ(count_lines(text), 9 + 1 + 1) << text;  // 10%..90%, the detail, done
}

TEST(Progress, VerboseStepThatJumpsToItsEndPrintsOnlyItsDoneLine) {
  Captured out;
  {
    ProgressBar bar(Verbosity::kVerbose, out.file.get(), false);
    bar.update("3d view", 0.0);
    bar.update("3d view", 1.0);
    bar.update("report", 0.0);
    bar.update("report", 0.55);  // crosses five tenths at once: one line
    bar.update("report", 1.0);
  }
  const std::string text = out.text();
  EXPECT_EQ(count_lines(text), 1 + 1 + 1) << text;  // 3d view done, report 55%, report done
  EXPECT_NE(text.find("3d view    done in"), std::string::npos) << text;
}

TEST(Progress, QuietPrintsNothing) {
  Captured out;
  {
    ProgressBar bar(Verbosity::kQuiet, out.file.get(), true);
    bar.update("rough", 0.5);
    bar.log("message");
  }
  EXPECT_TRUE(out.text().empty());
}

TEST(Progress, TerminalRedrawsInPlaceAndWorkersMayReportConcurrently) {
  Captured out;
  {
    ProgressBar bar(Verbosity::kNormal, out.file.get(), true);
    auto report = bar.callback();
    std::vector<std::thread> workers;
    for (int w = 0; w < 4; ++w) {
      workers.emplace_back([&report, w] {
        for (int i = 0; i < 200; ++i) report("rough", (w * 200 + i) / 800.0);
      });
    }
    for (auto& t : workers) t.join();
  }
  const std::string text = out.text();
  EXPECT_NE(text.find('\r'), std::string::npos);
  EXPECT_EQ(count_lines(text), 1) << "only the finished step ends a line";
  EXPECT_NE(text.find("rough      done in"), std::string::npos);
}

TEST(Progress, TablesAlignNumbersRight) {
  const std::string table = text_table({"dof", "value"}, {{"x", "1.5"}, {"roll", "-10.25"}});
  EXPECT_EQ(table,
            "dof   value\n"
            "------------\n"
            "x        1.5\n"
            "roll  -10.25\n");
}

}  // namespace
}  // namespace insalign::cli
