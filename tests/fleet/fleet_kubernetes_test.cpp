// The Kubernetes engine's Indexed Job and Dockerfile: their content, and the Job's command run
// here once per completion index as the pods would run it.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "fleet/status.hpp"
#include "fleet_test_util.hpp"
#include "files/read_file.hpp"

namespace insalign::testing {
namespace {

TEST(FleetKubernetes, IndexedJobAndDockerfile) {
  const FleetDrives& d = fleet_drives();
  const fs::path manifest = write_manifest(d.dir / "k8s.csv", calibrate_row("carA", "2026-01-01", "a") +
                                                                  calibrate_row("carC", "2026-01-01", "corrupt"));
  const ScratchDir scratch("insalign_fleet_k8s", "");
  const fs::path results = scratch.path() / "results";
  const auto [rc, out] = run_command(exe() + " fleet run " + manifest.string() + " --results " + results.string() +
                                     " --engine kubernetes --jobs 3 --image registry.example/insalign:1 --volume-claim fleet-pvc");
  ASSERT_EQ(rc, 0) << out;
  EXPECT_TRUE(contains(out, "kubectl apply -f " + (results / "kubernetes" / "fleet-job.yaml").string())) << out;
  const YAML::Node job = YAML::LoadFile((results / "kubernetes" / "fleet-job.yaml").string());
  EXPECT_EQ(job["kind"].as<std::string>(), "Job");
  const YAML::Node spec = job["spec"];
  EXPECT_EQ(spec["completionMode"].as<std::string>(), "Indexed");
  EXPECT_EQ(spec["completions"].as<int>(), 2);
  EXPECT_EQ(spec["parallelism"].as<int>(), 3);
  EXPECT_GE(spec["backoffLimitPerIndex"].as<int>(), 1);
  const YAML::Node pod = spec["template"]["spec"];
  EXPECT_EQ(pod["restartPolicy"].as<std::string>(), "Never");
  const YAML::Node container = pod["containers"][0];
  EXPECT_EQ(container["image"].as<std::string>(), "registry.example/insalign:1");
  EXPECT_EQ(container["env"][0]["name"].as<std::string>(), "JOB_COMPLETION_INDEX");
  EXPECT_TRUE(container["resources"]["requests"]["memory"]);
  std::vector<std::string> command = container["command"].as<std::vector<std::string>>();
  ASSERT_GE(command.size(), 6u);
  EXPECT_EQ(std::vector<std::string>(command.begin() + 1, command.begin() + 4),
            (std::vector<std::string>{"fleet", "task", manifest.string()}));
  EXPECT_EQ(std::count(command.begin(), command.end(), "--index"), 0);  // the index comes from JOB_COMPLETION_INDEX
  // The volume holds the manifest, its recordings and the results, at the same paths.
  const std::string mount = container["volumeMounts"][0]["mountPath"].as<std::string>();
  EXPECT_EQ(pod["volumes"][0]["persistentVolumeClaim"]["claimName"].as<std::string>(), "fleet-pvc");
  EXPECT_EQ(manifest.string().rfind(mount, 0), 0u) << mount;
  EXPECT_EQ(results.string().rfind(mount, 0), 0u) << mount;

  const std::string docker = io::read_file(results / "kubernetes" / "Dockerfile");
  EXPECT_TRUE(contains(docker, "FROM debian:12"));
  EXPECT_TRUE(contains(docker, "RUN bash /src/scripts/install-deps.sh"));  // the same packages as a set-up machine
  EXPECT_TRUE(contains(docker, "/usr/local/bin/insalign"));
  EXPECT_EQ(command[0], "/usr/local/bin/insalign");
  EXPECT_TRUE(fs::exists(fs::path(INSALIGN_SOURCE_DIR) / "scripts" / "install-deps.sh"));

  // What each pod runs, here: the row from JOB_COMPLETION_INDEX.
  command[0] = exe();
  std::string line;
  for (const std::string& word : command) line += "'" + word + "' ";
  for (int index : {0, 1}) {
    const auto [task_rc, task_out] = run_command("JOB_COMPLETION_INDEX=" + std::to_string(index) + " " + line);
    EXPECT_EQ(task_rc, 0) << task_out;
  }
  fleet::ManifestRow a{"carA", "2026-01-01", "calibrate", "", "", "", 0}, c{"carC", "2026-01-01", "calibrate", "", "", "", 0};
  EXPECT_EQ(fleet::read_status(results, a).value().exit_code, 0);
  EXPECT_EQ(fleet::read_status(results, c).value().exit_code, 2);
}

}  // namespace
}  // namespace insalign::testing
