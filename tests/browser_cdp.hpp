// Headless Chromium driven over its DevTools protocol (CDP) through a pipe
// (--remote-debugging-pipe: JSON messages ended by a NUL byte on fds 3 and 4), so that a test
// sends a page real mouse, wheel and key events as a person would, with Debian's `chromium` alone:
// no port, no network, no WebDriver, no npm. One browser serves a whole test (a few seconds).
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace insalign::testing {

/// Whether Debian's chromium is installed (tests skip themselves, saying why, where it is not).
inline bool have_chromium() { return std::system("command -v chromium > /dev/null 2>&1") == 0; }

/// Base64 text decoded (CDP sends screenshots so; the viewer writes its points so).
inline std::string decode_base64(const std::string& s) {
  static const std::string table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::uint32_t v = 0;
  int bits = 0;
  for (char c : s) {
    const std::size_t p = table.find(c);
    if (p == std::string::npos) break;
    v = (v << 6) | static_cast<std::uint32_t>(p);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((v >> bits) & 0xff);
    }
  }
  return out;
}

class Browser {
 public:
  /// A headless Chromium with software WebGL (SwiftShader), its window width x height pixels.
  Browser(const std::filesystem::path& profile, int width, int height) {
    ::signal(SIGPIPE, SIG_IGN);  // a browser that died must fail the call, not kill the test
    int to[2], from[2];
    if (::pipe(to) != 0 || ::pipe(from) != 0) throw std::runtime_error("pipe failed");
    const std::vector<std::string> args = {"chromium", "--headless", "--no-sandbox", "--enable-unsafe-swiftshader",
                                           "--use-angle=swiftshader", "--no-first-run", "--disable-extensions",
                                           "--disable-background-networking", "--remote-debugging-pipe",
                                           "--user-data-dir=" + profile.string(),
                                           "--window-size=" + std::to_string(width) + "," + std::to_string(height),
                                           "about:blank"};
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, to[0], 3);
    posix_spawn_file_actions_adddup2(&fa, from[1], 4);
    posix_spawn_file_actions_addopen(&fa, 1, (profile.string() + ".log").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    const int rc = posix_spawnp(&pid_, "chromium", &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    ::close(to[0]);
    ::close(from[1]);
    write_fd_ = to[1];
    read_fd_ = from[0];
    if (rc != 0) throw std::runtime_error("could not start chromium");
    const nlohmann::json targets = send("Target.getTargets", nlohmann::json::object(), "");
    for (const auto& t : targets["targetInfos"])
      if (t["type"] == "page") {
        session_ = send("Target.attachToTarget", {{"targetId", t["targetId"]}, {"flatten", true}}, "")["sessionId"].get<std::string>();
        break;
      }
    if (session_.empty()) throw std::runtime_error("chromium has no page");
    send("Runtime.enable");
    send("Page.enable");
  }
  ~Browser() {
    try {
      send("Browser.close", nlohmann::json::object(), "", 5.0);
    } catch (...) {
    }
    ::close(write_fd_);
    ::close(read_fd_);
    int status = 0;
    for (int i = 0; i < 50 && ::waitpid(pid_, &status, WNOHANG) == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (::waitpid(pid_, &status, WNOHANG) == 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, &status, 0);
    }
  }
  Browser(const Browser&) = delete;
  Browser& operator=(const Browser&) = delete;

  /// A CDP command on the page (session "" : the browser); its result, or throws with its error.
  nlohmann::json send(const std::string& method, nlohmann::json params = nlohmann::json::object(),
                      std::optional<std::string> session = std::nullopt, double timeout_s = 20.0) {
    nlohmann::json msg = {{"id", ++id_}, {"method", method}, {"params", params}};
    const std::string s = session.value_or(session_);
    if (!s.empty()) msg["sessionId"] = s;
    const std::string text = msg.dump() + '\0';
    if (::write(write_fd_, text.data(), text.size()) != static_cast<ssize_t>(text.size()))
      throw std::runtime_error("chromium is gone (" + method + ")");
    const auto until = std::chrono::steady_clock::now() +
                       std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(timeout_s));
    for (;;) {
      const nlohmann::json reply = next_message(until, method);
      if (reply.contains("id") && reply["id"] == id_) {
        if (reply.contains("error")) throw std::runtime_error(method + ": " + reply["error"].dump());
        return reply["result"];
      }
      if (reply.value("method", "") == "Runtime.exceptionThrown")
        errors.push_back(reply["params"]["exceptionDetails"].dump());
      if (reply.value("method", "") == "Runtime.consoleAPICalled" && reply["params"].value("type", "") == "error")
        errors.push_back(reply["params"]["args"].dump());
    }
  }
  /// A JavaScript expression's value (reads the page: the tests do not call its handlers).
  nlohmann::json eval(const std::string& expression) {
    const nlohmann::json r = send("Runtime.evaluate", {{"expression", expression}, {"returnByValue", true}});
    return r["result"].contains("value") ? r["result"]["value"] : nlohmann::json();
  }
  void navigate(const std::string& url) { send("Page.navigate", {{"url", url}}); }
  /// Polls `expression` until it is true (false: timed out).
  bool wait_for(const std::string& expression, double timeout_s = 10.0) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < until) {
      if (eval("!!(" + expression + ")") == true) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(30));
    }
    return false;
  }
  std::string screenshot_png() {
    return decode_base64(send("Page.captureScreenshot", {{"format", "png"}})["data"].get<std::string>());
  }

  // ---- Input as a person gives it (CDP Input domain: the browser makes the DOM events) ----------
  static constexpr int kShift = 8;
  void mouse(const std::string& type, double x, double y, const std::string& button = "none", int buttons = 0,
             int modifiers = 0, int clicks = 0) {
    send("Input.dispatchMouseEvent", {{"type", type}, {"x", x}, {"y", y}, {"button", button}, {"buttons", buttons},
                                      {"modifiers", modifiers}, {"clickCount", clicks}});
  }
  /// Press at (x0, y0), move in steps to (x1, y1), release ("left" or "right" button).
  void drag(double x0, double y0, double x1, double y1, const std::string& button = "left", int modifiers = 0) {
    const int bit = button == "right" ? 2 : 1;
    mouse("mouseMoved", x0, y0, "none", 0, modifiers);
    mouse("mousePressed", x0, y0, button, bit, modifiers, 1);
    for (int k = 1; k <= 8; ++k)
      mouse("mouseMoved", x0 + (x1 - x0) * k / 8, y0 + (y1 - y0) * k / 8, button, bit, modifiers);
    mouse("mouseReleased", x1, y1, button, 0, modifiers, 1);
  }
  void click(double x, double y) {
    mouse("mouseMoved", x, y);
    mouse("mousePressed", x, y, "left", 1, 0, 1);
    mouse("mouseReleased", x, y, "left", 0, 0, 1);
  }
  void wheel(double x, double y, double delta_y) {
    send("Input.dispatchMouseEvent", {{"type", "mouseWheel"}, {"x", x}, {"y", y}, {"deltaX", 0}, {"deltaY", delta_y}});
  }
  /// A key with a printable character (e.g. "b", "1").
  void key(const std::string& k) {
    send("Input.dispatchKeyEvent", {{"type", "keyDown"}, {"key", k}, {"text", k}});
    send("Input.dispatchKeyEvent", {{"type", "keyUp"}, {"key", k}});
  }

  std::vector<std::string> errors;  ///< uncaught exceptions and console.error calls seen so far

 private:
  nlohmann::json next_message(std::chrono::steady_clock::time_point until, const std::string& waiting_for) {
    for (;;) {
      const std::size_t end = buffer_.find('\0');
      if (end != std::string::npos) {
        const std::string text = buffer_.substr(0, end);
        buffer_.erase(0, end + 1);
        return nlohmann::json::parse(text);
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - std::chrono::steady_clock::now());
      pollfd p{read_fd_, POLLIN, 0};
      if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) <= 0)
        throw std::runtime_error("chromium did not answer " + waiting_for + " in time");
      char chunk[65536];
      const ssize_t n = ::read(read_fd_, chunk, sizeof chunk);
      if (n <= 0) throw std::runtime_error("chromium is gone (" + waiting_for + ")");
      buffer_.append(chunk, static_cast<std::size_t>(n));
    }
  }
  pid_t pid_ = -1;
  int write_fd_ = -1, read_fd_ = -1;
  int id_ = 0;
  std::string session_;
  std::string buffer_;
};

}  // namespace insalign::testing
