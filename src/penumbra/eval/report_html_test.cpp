// End-to-end: the comparison page opens in headless Chromium without console errors,
// shows every image, and its zoom draws every crop. Skips (with a message) where Chromium
// is not installed; `scripts/setup.sh --with-test-tools` installs it, and CI uses that.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <regex>

#include "penumbra/eval/comparison.h"
#include "penumbra/testing/compare_fixture.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::slurp;
using testing::TempDir;

// The Chromium binary: $PENUMBRA_CHROMIUM if set (a name on PATH or a path), else chromium or
// chromium-browser on PATH; empty when there is none.
std::string find_chromium() {
  std::vector<std::string> names = {"chromium", "chromium-browser"};
  if (const char* c = std::getenv("PENUMBRA_CHROMIUM"); c && *c) names = {c};
  for (const std::string& name : names) {
    std::string cmd = fmt::format("command -v '{}' >/dev/null 2>&1", name);
    if (std::system(cmd.c_str()) == 0) return name;
  }
  return "";
}

struct BrowserRun {
  int exit_code = -1;
  std::string dom, log;
};

BrowserRun dump_dom(const std::string& chromium, const std::filesystem::path& page, const std::string& hash,
                    const TempDir& dir) {
  std::string dom = (dir / "dom.html").string(), log = (dir / "chromium.log").string();
  // A profile of its own: tests may run in parallel.
  std::string cmd = fmt::format(
      "timeout 120 {} --headless --disable-gpu --no-sandbox --no-first-run --user-data-dir={} "
      "--enable-logging=stderr --v=0 --dump-dom 'file://{}{}' >{} 2>{}",
      chromium, (dir / "profile").string(), std::filesystem::absolute(page).string(), hash, dom, log);
  int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(dom), slurp(log)};
}

TEST(ReportHtml, OpensInHeadlessChromiumWithEveryImageAndNoConsoleErrors) {
  std::string chromium = find_chromium();
  if (chromium.empty())
    GTEST_SKIP() << "chromium is not installed: the browser test of the comparison page is skipped "
                    "(install it with scripts/setup.sh --with-test-tools, or set PENUMBRA_CHROMIUM)";
  TempDir dir;
  CompareOptions o;
  o.methods = {"reference", "hard", "single-sample"};
  o.cache_dir = dir / "cache";
  RunSetup setup = testing::tiny_contact_setup();
  setup.apply("hard.bogus", "1");  // a failed method's card has no image and must not break the page
  Comparison c = run_comparison(setup, o);
  c.command = "penumbra compare 'scenes/contact.json' <test> & \"quotes\"";
  write_comparison(c, dir / "out");
  const size_t expected_images = 2 + 3 * 2;  // ground truth: colour, V; reference and single-sample: 3 each

  BrowserRun run = dump_dom(chromium, dir / "out" / "index.html", "#selftest", dir);
  ASSERT_EQ(run.exit_code, 0) << run.log;
  std::smatch m;
  static const std::regex body_re("<body([^>]*)>");
  ASSERT_TRUE(std::regex_search(run.dom, m, body_re)) << run.dom.substr(0, 2000);
  std::string attrs = m[1];
  auto attr = [&](const std::string& name) {
    std::smatch a;
    std::regex re(name + "=\"([^\"]*)\"");
    return std::regex_search(attrs, a, re) ? std::string(a[1]) : std::string("(absent)");
  };
  EXPECT_EQ(attr("data-images-total"), std::to_string(expected_images));
  EXPECT_EQ(attr("data-images-loaded"), std::to_string(expected_images)) << "an image did not decode";
  EXPECT_EQ(attr("data-selftest"), "ok") << "the zoom did not draw every crop";

  // Console output of the page (errors, uncaught exceptions, logs) appears as
  // "...:CONSOLE(line)] message" lines; the page writes none.
  std::istringstream lines(run.log);
  for (std::string line; std::getline(lines, line);) {
    EXPECT_EQ(line.find(":CONSOLE"), std::string::npos) << line;
    EXPECT_EQ(line.find("Uncaught"), std::string::npos) << line;
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
