// The apps as a user runs them: exit codes, one-line errors on stderr, JSON on stdout.
#include "test_files.hpp"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace {

using obsgain_test::read_text;
using obsgain_test::write_temp_file;

struct AppRun {
  int exit_code;
  std::string out, err;
};

AppRun run(const std::string& app, const std::string& arguments, const std::string& environment = "") {
  // ctest runs these tests in parallel processes: one stderr file per process and call.
  static int call = 0;
  const std::string err_file =
      ::testing::TempDir() + "/obsgain_stderr_" + std::to_string(getpid()) + "_" + std::to_string(call++) + ".txt";
  const std::string command = (environment.empty() ? "" : "env " + environment + " ") + std::string(OBSGAIN_APP_DIR) +
                              "/" + app + " " + arguments + " 2>" + err_file;
  FILE* pipe = popen(command.c_str(), "r");
  std::string out;
  std::array<char, 4096> buffer{};
  while (size_t n = fread(buffer.data(), 1, buffer.size(), pipe)) out.append(buffer.data(), n);
  const int status = pclose(pipe);
  std::ifstream err_stream(err_file);
  std::stringstream err;
  err << err_stream.rdbuf();
  std::remove(err_file.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out, err.str()};
}

void expect_refused(const std::string& arguments, const std::string& names, const std::string& app = "design-gains") {
  const AppRun r = run(app, arguments);
  EXPECT_EQ(r.exit_code, 2) << arguments;
  EXPECT_TRUE(r.out.empty()) << arguments;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find(names), std::string::npos) << "'" << r.err << "' should name " << names;
}

nlohmann::json read_json(const std::string& path) {
  std::ifstream file(path);
  return nlohmann::json::parse(file);
}

TEST(DesignGainsApp, RefusesBadInputWithOneLineAndExit2) {
  expect_refused("--gamma -1", "gamma = -1");
  expect_refused("--gamma 0", "gamma = 0");
  expect_refused("--gamma nan", "gamma");
  expect_refused("--gamma abc", "--gamma = 'abc' is not a decimal number");
  expect_refused("--theta -5", "theta = -5");
  expect_refused("--gamma 1 --theta 100", "exactly one");
  expect_refused("", "exactly one");
  expect_refused("--gamma 1 --alpha 0", "alpha = 0");
  expect_refused("--gamma 1 --beta -1", "beta = -1");
  expect_refused("--gamma 1 --alpha nan", "alpha");
  expect_refused("--gamma 1 --vmax 0,10", "V1 = 0");
  expect_refused("--gamma 1 --vmax 10,-3", "V2 = -3");
  expect_refused("--gamma 1 --vmax 10,nan", "vmax");
  expect_refused("--gamma 1 --vmax 10,10,10", "3 bound(s)");
  expect_refused("--robot nope --gamma 1", "unknown robot 'nope'");
  expect_refused("--gamma 1 --L 0", "L = 0");
  expect_refused("--gamma 1 --certificate best", "certificate");
  expect_refused("--gamma 1 --bounds guessed", "bounds");
  expect_refused("--gamma 1 --optimize-shape --alpha 2", "optimize-shape");
  expect_refused("--gamma 1 --no-such-flag", "no-such-flag");
  expect_refused("--robot /nonexistent/arm.json --gamma 1", "cannot read model file '/nonexistent/arm.json'");
}

// Values that used to hang, overflow or be read wrongly: each refused with one line naming it.
TEST(DesignGainsApp, RefusesValuesOutsideTheAdmissibleRanges) {
  expect_refused("--gamma 1e300", "--gamma = 1e+300 must lie in");
  expect_refused("--theta 1e300", "--theta = 1e+300 must lie in");
  expect_refused("--theta 1e-300", "--theta = 1e-300 must lie in");
  expect_refused("--gamma 0x10", "--gamma = '0x10' is not a decimal number");
  // Below the smallest double it named 0, the value read in its place: it names what was typed.
  expect_refused("--gamma 5e-400", "--gamma = 5e-400 is below the smallest normal double (2.2e-308) in magnitude");
  expect_refused("--gamma 1 --vmax 1,1e-320", "--vmax = 1e-320 is below the smallest normal double");
  expect_refused("--gamma \"\" --theta 10", "--gamma = '' is empty");
  expect_refused("--gamma 1 --vmax \"\"", "--vmax = '' is empty");
  expect_refused("--gamma 1 --vmax 1e300,1e300", "V1 = 1e+300 (--vmax) must lie in");
  // A list's last empty item is refused as an inner one is (it was dropped: "1,2," read as two values).
  expect_refused("--gamma 1 --vmax 1,1,", "--vmax = '' is not a decimal number");
  expect_refused("--robot " + std::string(OBSGAIN_EXAMPLES_DIR) + "/arm3.urdf --gamma 1 --joint-limits c,-1:1,c,",
                 "--joint-limits: range 4 = '' is not lower:upper or c");
  expect_refused("--gamma 1 --bound-budget -1", "--bound-budget = -1");
  expect_refused("--gamma 1 --proof-budget 0", "--proof-budget = 0 must lie in (0, 1e6]");
  expect_refused("--gamma 1 --proof-budget 1e7", "--proof-budget = 10000000 must lie in");
  expect_refused("--gamma 1 --proof-budget \"\"", "--proof-budget = '' is empty");
  const std::string directory = ::testing::TempDir() + "/obsgain_directory.json";
  std::filesystem::create_directories(directory);
  expect_refused("--robot " + directory + " --gamma 1", "(not a file)");
  expect_refused("--design " + directory, "(not a file)", "monte-carlo");
  const std::string overflow = ::testing::TempDir() + "/obsgain_overflow.json";
  std::ofstream(overflow) << R"({"name": "x", "type": "planar_2r", "pi": [1e999, 0.01, 0.009, 0.2, 0.06]})";
  expect_refused("--robot " + overflow + " --gamma 1", overflow);
  const std::string huge = ::testing::TempDir() + "/obsgain_huge.json";
  {
    std::ofstream file(huge);
    file << R"({"name": "x", "type": "planar_2r", "pi": [)";
    for (int i = 0; i < 100000; ++i) file << (i ? ", " : "") << "0.01";
    file << "]}";
  }
  const AppRun r = run("design-gains", "--robot " + huge + " --gamma 1");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_LT(r.err.size(), 300u) << "the echoed value is cut";
  expect_refused("--theta 200 --rtol 2", "--rtol = 2 must lie in", "monte-carlo");
  expect_refused("--theta 200 --horizon 1e9", "--horizon = 1000000000 must lie in", "monte-carlo");
  expect_refused("--theta 200 --threads 10000", "--threads = 10000", "monte-carlo");
  expect_refused("--theta 200 --step-budget 0", "--step-budget = 0 must be at least 1", "monte-carlo");
  expect_refused("--theta 200 --step-budget \"\"", "--step-budget = '' is not a decimal number", "monte-carlo");
}

// A design file fixes the robot and the gains: design options beside it, or a model file changed since the
// design, are refused rather than silently ignored or checked against the wrong robot.
TEST(MonteCarloApp, DesignFileIsTheWholeTruth) {
  const std::string model = write_temp_file("obsgain_changing.json", read_text(std::string(OBSGAIN_EXAMPLES_DIR) + "/pendubot.json"));
  const std::string design = ::testing::TempDir() + "/obsgain_changing_design.json";
  ASSERT_EQ(run("design-gains", "--robot " + model + " --gamma 1.27 --bounds numeric --json " + design).exit_code, 0);
  expect_refused("--design " + design + " --robot pendubot", "--robot cannot be given with it", "monte-carlo");
  expect_refused("--design " + design + " --gamma 3", "--gamma cannot be given with it", "monte-carlo");
  // Threads are the simulation's, not the design's: no result depends on them.
  EXPECT_EQ(run("monte-carlo", "--design " + design + " --trials 2 --horizon 0.1 --threads 1").exit_code, 0);
  nlohmann::json renamed = nlohmann::json::parse(read_text(design));
  ASSERT_EQ(renamed.at("design").at("certificate").get<std::string>(), "scaled");
  renamed["design"]["certificate"] = "sos";  // not a certificate this version knows: not read as another one
  expect_refused("--design " + write_temp_file("obsgain_unknown_certificate.json", renamed.dump()) + " --trials 2",
                 "design.certificate 'sos' is not one of", "monte-carlo");
  // An edited design that no longer holds together is no certificate to validate: a k1 of −1 was simulated and
  // reported as a violated certificate (exit 1), and a P of −I passed every Lyapunov check.
  const auto edited = [&](const char* key, const nlohmann::json& value) {
    nlohmann::json j = nlohmann::json::parse(read_text(design));
    j["design"][key] = value;
    return "--design " + write_temp_file("obsgain_edited_design.json", j.dump()) + " --trials 2";
  };
  expect_refused(edited("k1", -1), "design.k1 = -1 must be positive", "monte-carlo");
  expect_refused(edited("theta", 10), "design.k1 = ", "monte-carlo");
  expect_refused(edited("L", -1), "design.L = -1 must be >= 0", "monte-carlo");
  expect_refused(edited("P", nlohmann::json::parse("[[-1,0,0,0],[0,-1,0,0],[0,0,-1,0],[0,0,0,-1]]")),
                 "design.P must be symmetric positive definite", "monte-carlo");
  std::ofstream(model, std::ios::app) << "\n";  // the same robot, but the file changed: the design may be stale
  expect_refused("--design " + design + " --trials 2", "run design-gains again", "monte-carlo");
}

// A gain of 20,000 makes the error dynamics stiff: 1000 trials of 1 s would simulate for hours. The run is refused
// as a request that cannot be met (exit 1, one line saying what would help); a short run of the same design is
// simulated; verify-bounds still writes its report, saying why there is no Monte Carlo.
TEST(MonteCarloApp, AGainTooStiffToSimulateExitsOneAndSaysWhatWouldHelp) {
  const std::string design = ::testing::TempDir() + "/obsgain_stiff_design.json";
  ASSERT_EQ(run("design-gains", "--theta 20000 --bounds numeric --quiet --json " + design).exit_code, 0);
  const AppRun refused = run("monte-carlo", "--design " + design);
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_TRUE(refused.out.empty());
  EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1) << refused.err;
  for (const char* hint : {"not simulated", "--step-budget", "--horizon", "--trials"})
    EXPECT_NE(refused.err.find(hint), std::string::npos) << hint << ": " << refused.err;
  EXPECT_EQ(run("monte-carlo", "--design " + design + " --trials 2 --horizon 0.005").exit_code, 0);
  const std::string out = ::testing::TempDir() + "/obsgain_stiff_report";
  const AppRun report = run("verify-bounds", "--theta 20000 --bounds numeric --quiet --out " + out);
  EXPECT_EQ(report.exit_code, 1);
  EXPECT_NE(report.err.find("Monte Carlo not simulated"), std::string::npos) << report.err;
  const nlohmann::json written = read_json(out + "/report.json");
  EXPECT_NE(written.at("monte_carlo").at("not_run").get<std::string>().find("--step-budget"), std::string::npos);
  EXPECT_NE(read_text(out + "/report.html").find("Monte Carlo not simulated"), std::string::npos);
}

TEST(DesignGainsApp, JsonOnStdoutAndTableOtherwise) {
  const AppRun j = run("design-gains", "--robot pendubot --gamma 1.27 --json");  // certified bounds: the default
  ASSERT_EQ(j.exit_code, 0) << j.err;
  const nlohmann::json design = nlohmann::json::parse(j.out);
  EXPECT_NEAR(design["bounds"]["L_joint"].get<double>(), 43.3475, 1e-5 * 43.3475);
  EXPECT_EQ(design["bounds"]["method"], "certified");
  EXPECT_TRUE(design["certified"].get<bool>());
  EXPECT_LE(design["bounds"]["brackets"]["L_joint"]["lower"].get<double>(), design["bounds"]["L_joint"].get<double>());
  EXPECT_EQ(design["bounds"]["brackets"]["L_joint"]["upper"].get<double>(), design["bounds"]["L_joint"].get<double>());
  const AppRun c = run("design-gains", "--robot pendubot --gamma 1.27");
  EXPECT_NE(c.out.find("  certified: ||e(t)||"), std::string::npos) << c.out;
  // Numeric bounds by request: an estimate, never called certified (exit 0: the user asked for it).
  const AppRun t = run("design-gains", "--robot pendubot --gamma 1.27 --bounds numeric");
  ASSERT_EQ(t.exit_code, 0) << t.err;
  EXPECT_NE(t.out.find("theta* (smallest gain for the target)"), std::string::npos);
  EXPECT_EQ(t.out.find("certified: ||e(t)||"), std::string::npos) << t.out;
  EXPECT_NE(t.out.find("estimate (numeric bounds, not proven): ||e(t)||"), std::string::npos) << t.out;
  const nlohmann::json numeric =
      nlohmann::json::parse(run("design-gains", "--robot pendubot --gamma 1.27 --bounds numeric --json").out);
  EXPECT_FALSE(numeric["certified"].get<bool>());
  EXPECT_NE(numeric["certified_reason"].get<std::string>().find("--bounds numeric"), std::string::npos);
}

TEST(DesignGainsApp, VersionAndJsonDashMeanStdout) {
  for (const char* app : {"design-gains", "monte-carlo", "verify-bounds"}) {
    const AppRun v = run(app, "--version");
    EXPECT_EQ(v.exit_code, 0) << app;
    EXPECT_EQ(v.out.rfind("obsgain ", 0), 0u) << app << ": " << v.out;
  }
  const AppRun j = run("design-gains", "--robot pendubot --gamma 1.27 --bounds numeric --json -");
  ASSERT_EQ(j.exit_code, 0) << j.err;
  EXPECT_NEAR(nlohmann::json::parse(j.out)["bounds"]["L_joint"].get<double>(), 43.3475, 1e-4);
}

TEST(DesignGainsApp, JsonToFile) {
  const std::string path = ::testing::TempDir() + "/obsgain_design.json";
  const AppRun r = run("design-gains", "--gamma 2 --certificate paper --bounds numeric --json " + path);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream file(path);
  const nlohmann::json design = nlohmann::json::parse(file);
  EXPECT_EQ(design["certificate"], "paper");
  EXPECT_DOUBLE_EQ(design["design"]["gamma"].get<double>(), 2.0);
}

TEST(MonteCarloApp, ValidatesASavedDesign) {
  const std::string design = ::testing::TempDir() + "/obsgain_mc_design.json";
  ASSERT_EQ(run("design-gains", "--gamma 1.27 --bounds numeric --json " + design).exit_code, 0);
  const std::string csv = ::testing::TempDir() + "/obsgain_trials.csv";
  const std::string trajectory = ::testing::TempDir() + "/obsgain_trajectory.csv";
  const AppRun r = run("monte-carlo", "--design " + design + " --trials 20 --seed 3 --horizon 0.5 --json --csv " + csv +
                                          " --trajectory " + trajectory);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << "no progress line when stderr is not a terminal: " << r.err;
  const nlohmann::json report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["trials"], 20);
  EXPECT_EQ(report["envelope_violations"], 0);
  EXPECT_DOUBLE_EQ(report["certified_gamma"].get<double>(), 1.27);
  std::ifstream rows(csv);
  EXPECT_EQ(std::count(std::istreambuf_iterator<char>(rows), {}, '\n'), 21);
  std::ifstream series(trajectory);
  std::string header;
  std::getline(series, header);
  EXPECT_EQ(header, "t,q1,q2,v1,v2,qhat1,qhat2,vhat1,vhat2,error_norm,envelope");
}

TEST(Urdf, DesignAndValidateAThreeJointArm) {
  const std::string examples = OBSGAIN_EXAMPLES_DIR;
  const std::string design = ::testing::TempDir() + "/obsgain_arm3_design.json";
  const AppRun d = run("design-gains", "--robot " + examples + "/arm3.urdf --gamma 5 --bounds numeric --json " + design);
  ASSERT_EQ(d.exit_code, 0) << d.err;
  // The joints searched, by name: not q1 (it moves the whole chain), q3 too (the forearm is not symmetric about it).
  EXPECT_NE(d.err.find("bounds: numeric search over q2, q3 (M and C do not depend on the other joints"), std::string::npos) << d.err;
  const nlohmann::json j = read_json(design);
  EXPECT_EQ(j["robot"]["name"], "arm3");
  EXPECT_EQ(j["robot"]["dof"], 3);
  EXPECT_TRUE(j["robot"]["source"].get<std::string>().ends_with("/examples/arm3.urdf"));
  EXPECT_TRUE(j["design"]["certified"].get<bool>());
  // monte-carlo reloads the URDF named in the design: computed-torque tracking, three joints.
  const AppRun r = run("monte-carlo", "--design " + design + " --trials 4 --horizon 0.3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["passed"], 4);
  EXPECT_DOUBLE_EQ(report["certified_gamma"].get<double>(), 5.0);
}

// A single joint: nothing to search (M is constant, A = 0), and the design and its validation still work.
TEST(Urdf, AOneJointRobotIsDesignedAndValidated) {
  const std::string examples = OBSGAIN_EXAMPLES_DIR;
  const std::string design = ::testing::TempDir() + "/obsgain_pendulum_design.json";
  const AppRun d = run("design-gains", "--robot " + examples + "/pendulum.urdf --gamma 5 --json " + design);
  ASSERT_EQ(d.exit_code, 0) << d.err;
  const nlohmann::json j = read_json(design);
  EXPECT_TRUE(j["design"]["certified"].get<bool>());
  // M = I_yy + m l² = 0.02 + 1 · 0.5² (the model's inertia about the hinge).
  const auto& M0 = j["bounds"]["brackets"]["M0"];
  EXPECT_NEAR(M0["lower"].get<double>(), 1.0 / 0.27, 1e-12);
  EXPECT_NEAR(M0["upper"].get<double>(), 1.0 / 0.27, 1e-12);
  EXPECT_LT(j["bounds"]["brackets"]["L_joint"]["upper"].get<double>(), 1e-100);
  // Nothing perturbs the error (L = 0): the linear observer's rate, γ < θ/2, so θ* = 2γ. On numeric bounds L is 0
  // exactly, which the tight certificate refused (exit 2, "needs L > 0").
  EXPECT_NEAR(j["design"]["theta_star"].get<double>(), 10.0, 1e-6);  // the design's θ search stops within 1.2e-7 of it
  const AppRun numeric = run("design-gains", "--robot " + examples + "/pendulum.urdf --gamma 5 --bounds numeric --json");
  ASSERT_EQ(numeric.exit_code, 0) << numeric.err;
  const nlohmann::json n = nlohmann::json::parse(numeric.out);
  EXPECT_EQ(n["bounds"]["L_joint"].get<double>(), 0.0);
  EXPECT_NEAR(n["design"]["theta_star"].get<double>(), 10.0, 1e-6);  // the design's θ search stops within 1.2e-7 of it
  const AppRun r = run("monte-carlo", "--design " + design + " --trials 4 --horizon 0.3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["passed"], 4);
  // verify-bounds swept the first searched joint, of which there is none here (it crashed): flat curves along q1.
  const std::string out = ::testing::TempDir() + "/obsgain_pendulum_report";
  const AppRun v = run("verify-bounds", "--robot " + examples + "/pendulum.urdf --gamma 5 --trials 4 --quiet --out " + out);
  ASSERT_EQ(v.exit_code, 0) << v.err;
  std::istringstream csv(read_text(out + "/bound_curves.csv"));
  std::string line;
  std::getline(csv, line);
  ASSERT_EQ(line, "angle,inverse_inertia_norm,jacobian_norm,joint_lipschitz_norm");
  int points = 0;
  while (std::getline(csv, line)) {
    double angle = 0.0, M0 = 0.0, B = 0.0, L = 0.0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf", &angle, &M0, &B, &L), 4) << line;
    EXPECT_NEAR(M0, 1.0 / 0.27, 1e-9) << line;
    EXPECT_EQ(B, 0.0) << line;
    EXPECT_EQ(L, 0.0) << line;
    ++points;
  }
  EXPECT_EQ(points, 721);
}

// A search stopped before M(q)⁻¹ was bounded on every box proves nothing: an unmet request (exit 1) that says what
// would help, not bad input. (A chain of revolute joints has an inertia floor that bounds M⁻¹ on every box at once,
// bounds/inertia_floor.hpp; a two-link model file without rotor inertia has none.)
TEST(DesignGainsApp, AnUnfinishedBoundSearchExitsOneAndSaysWhatWouldHelp) {
  const std::string examples = OBSGAIN_EXAMPLES_DIR;
  const AppRun r =
      run("design-gains", "--robot " + examples + "/two_link_arm.json --gamma 5 --bound-budget 0.0001 --quiet");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("--bound-budget"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--armature"), std::string::npos) << r.err;
  // The table shows the bounds and why there is no design, not a design of zero gains or a gap of NaN.
  EXPECT_NE(r.out.find("Design: NOT CERTIFIED: L_joint has no finite proven upper bound"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("no finite upper bound yet"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("gains k1"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("nan"), std::string::npos) << r.out;
  // The report alike: the reason as its verdict, no gains, and still exit 1.
  const std::string out = ::testing::TempDir() + "/obsgain_unfinished_report";
  EXPECT_EQ(run("verify-bounds", "--robot " + examples + "/two_link_arm.json --gamma 5 --bound-budget 0.0001 --quiet --out " + out).exit_code, 1);
  const std::string html = read_text(out + "/report.html");
  EXPECT_NE(html.find("NOT CERTIFIED</span>: L_joint has no finite proven upper bound"), std::string::npos);
  EXPECT_EQ(html.find("Gains k1"), std::string::npos);
  // The bounds table says what stopped the searches, as the text report does.
  EXPECT_NE(html.find("</td><td>budget</td><td>q = "), std::string::npos) << html;
  // The bounds' plot draws the finite bound (B) and leaves out the infinite ones: gnuplot has no "inf".
  EXPECT_NE(html.find("<svg"), std::string::npos) << html;
  EXPECT_EQ(html.find("gnuplot failed"), std::string::npos) << html;
}

// A proof far above the value attained is still a proof, but its cost is named: a warning gives the factor and what
// narrows it, for the constant the selected certificate rests on. A converged bracket (the Pendubot's, 1e-6) gets none.
TEST(DesignGainsApp, AWideProvenBracketIsNamedInAWarning) {
  const std::string examples = OBSGAIN_EXAMPLES_DIR;
  const auto warnings = [](const AppRun& r) {
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    std::string all;
    for (const auto& w : j["warnings"]) all += w.get<std::string>() + "\n";
    return all;
  };
  // At 0.03 counted seconds L_joint is 17.3 times its value attained, its excess falling to 0.17 of itself per doubling
  // of the work over its second half: the warning carries that pace on to a budget, as the extrapolation it is.
  const AppRun paced = run("design-gains", "--robot " + examples + "/arm3.urdf --gamma 5 --bound-budget 0.03 --quiet --json");
  EXPECT_NE(warnings(paced).find("L_joint's proven upper end 672.685 is 17.3 times the value attained (38.7831): the "
                                 "certified gains pay for that gap (a larger --bound-budget narrows it; real arms have "
                                 "rotor inertia: --armature)"),
            std::string::npos)
      << warnings(paced);
  const nlohmann::json paced_joint = nlohmann::json::parse(paced.out)["bounds"]["brackets"]["L_joint"];
  ASSERT_TRUE(paced_joint["excess_per_doubling"].is_number()) << paced.out;
  const double pace = paced_joint["excess_per_doubling"].get<double>();
  EXPECT_NEAR(pace, 0.16645, 1e-4);  // counted work: the same on every machine (rules 29)
  // The budget at which that pace takes the excess to half the value attained (the bracket within 1.5 times).
  const double lower = paced_joint["lower"].get<double>(), upper = paced_joint["upper"].get<double>();
  const double budget = 0.03 * std::exp2(std::log2(0.5 * lower / (upper - lower)) / std::log2(pace));
  std::array<char, 160> expected{};
  std::snprintf(expected.data(), expected.size(),
                "fell to %.2g of itself lately: at that pace --bound-budget %.3g would bring it within 1.5 times, and ",
                pace, budget);
  const std::string extrapolated = warnings(paced);
  EXPECT_NE(extrapolated.find(expected.data()), std::string::npos) << expected.data() << "\n" << extrapolated;
  // and the budget for θ within 1.1 times its value on the value attained (Design tests check it through θ(L)).
  EXPECT_NE(extrapolated.find("--bound-budget 0.204 would bring theta within 1.1 times its value on the value attained "
                              "(an extrapolation, not a bound)"),
            std::string::npos)
      << extrapolated;
  const std::string converged = warnings(run("design-gains", "--robot pendubot --gamma 1.27 --quiet --json"));
  EXPECT_EQ(converged.find("times the value attained"), std::string::npos) << converged;
  // Named scaled, with L_T's proof behind: the warning is L_T's (the two-link arm's, 50 times its value attained).
  const std::string scaled = warnings(run(
      "design-gains", "--robot " + examples + "/two_link_arm.json --gamma 5 --bound-budget 0.0003 --certificate scaled --quiet --json"));
  EXPECT_NE(scaled.find("L_T's proven upper end"), std::string::npos) << scaled;
  // The two-link arm at this budget: L_T wins the race and is proven within 2 % (7.982 against 7.825), while L_joint
  // stopped after its first share at 8.8 times its value attained. The design rests on L_T: no warning.
  const AppRun won = run("design-gains", "--robot " + examples + "/two_link_arm.json --gamma 5 --bound-budget 0.0024 --quiet --json");
  const std::string narrow = warnings(won);
  const nlohmann::json j = nlohmann::json::parse(won.out);
  EXPECT_EQ(j["certificate"], "scaled");
  const nlohmann::json& joint = j["bounds"]["brackets"]["L_joint"];
  EXPECT_GT(joint["upper"].get<double>(), 5.0 * joint["lower"].get<double>());
  EXPECT_EQ(narrow.find("times the value attained"), std::string::npos) << narrow;
}

// The report's bounds table, and the text report's brackets, give a stopped search's pace beside what stopped it, as the
// JSON has it: the two-link arm's L_joint at this budget, its excess falling to 0.032 of itself per doubling of the work
// (measured).
TEST(VerifyBoundsApp, TheBoundsTableGivesAStoppedSearchsPace) {
  const std::string out = ::testing::TempDir() + "/obsgain_paced_report";
  const AppRun r = run("verify-bounds", "--robot " + std::string(OBSGAIN_EXAMPLES_DIR) +
                                            "/two_link_arm.json --gamma 5 --bound-budget 0.001 --trials 4 --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json joint = read_json(out + "/report.json")["certified"]["L_joint"];
  ASSERT_TRUE(joint["excess_per_doubling"].is_number()) << joint.dump();
  EXPECT_NEAR(joint["excess_per_doubling"].get<double>(), 0.031578, 1e-5);  // counted work (rules 29)
  std::array<char, 80> cell{};
  std::snprintf(cell.data(), cell.size(), "<td>budget; excess x %.2g per doubling of the work</td>",
                joint["excess_per_doubling"].get<double>());
  const std::string html = read_text(out + "/report.html");
  EXPECT_NE(html.find(cell.data()), std::string::npos) << cell.data();
  std::array<char, 100> line{};
  std::snprintf(line.data(), line.size(), "(stopped by the budget, --bound-budget; excess x %.2g per doubling of the work)\n",
                joint["excess_per_doubling"].get<double>());
  EXPECT_NE(r.out.find(line.data()), std::string::npos) << line.data() << r.out;
  // A search that reached its gap, or stopped with no point in its first half, has no pace to show.
  EXPECT_NE(html.find("<td>budget</td><td>q = "), std::string::npos);
}

// On arm7 NLopt and Ipopt stop at different local maxima of B (12.20 and 12.39, measured): on numeric bounds, whose
// value is the larger of the two, the warning names the bound and what would prove it; on certified bounds the
// design uses the bracket's proven upper end, and the disagreement is no warning.
TEST(DesignGainsApp, OptimisersThatDisagreeAreAWarningOnNumericBoundsOnly) {
  const std::string arm7 = std::string(OBSGAIN_EXAMPLES_DIR) + "/arm7.urdf";
  const auto warnings = [](const AppRun& r) {
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return nlohmann::json::parse(r.out)["warnings"].dump();
  };
  const std::string numeric = warnings(run("design-gains", "--robot " + arm7 + " --gamma 5 --bounds numeric --quiet --json"));
  EXPECT_NE(numeric.find("bound search: B: NLopt (12.20"), std::string::npos) << numeric;
  EXPECT_NE(numeric.find("--bounds certified proves it"), std::string::npos) << numeric;
  const std::string certified = warnings(run("design-gains", "--robot " + arm7 + " --gamma 5 --bound-budget 0.25 --quiet --json"));
  EXPECT_EQ(certified.find("bound search:"), std::string::npos) << certified;
}

// Every number in the JSON but the wall times is the same for one and two threads and on a second run: the search
// stops at a budget of counted work, not of wall time.
TEST(DesignGainsApp, TheSameJsonForAnyThreadCountAndOnEveryRun) {
  const std::string examples = OBSGAIN_EXAMPLES_DIR;
  const auto design = [&](int threads) {
    const AppRun r = run("design-gains", "--robot " + examples + "/arm3.urdf --gamma 5 --bound-budget 0.1 --quiet --json --threads " +
                                             std::to_string(threads));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    nlohmann::json j = nlohmann::json::parse(r.out);
    const auto strip = [](auto& self, nlohmann::json& x) -> void {
      if (x.is_object()) {
        x.erase("seconds");
        x.erase("wall_seconds");
      }
      if (x.is_structured())
        for (auto& child : x) self(self, child);
    };
    strip(strip, j);
    return j;
  };
  const nlohmann::json one = design(1);
  EXPECT_EQ(one["bounds"]["brackets"]["L_joint"]["stop"], "budget");  // the budget, not the gap, ended it
  // L_joint's upper end was lower after its share each.
  EXPECT_EQ(one["bounds"]["brackets"]["L_scaled"]["stop"], "race");
  EXPECT_EQ(one, design(2));
  EXPECT_EQ(one, design(2));
}

TEST(Urdf, MalformedRobotsExitTwoWithOneLine) {
  const std::string examples = OBSGAIN_EXAMPLES_DIR;
  const std::string broken = ::testing::TempDir() + "/obsgain_broken.urdf";
  std::ofstream(broken) << "<robot name='r'>\n<link name='a'>\n</robot>\n";
  expect_refused("--robot /nonexistent/arm.urdf --gamma 1", "cannot read URDF file '/nonexistent/arm.urdf'");
  expect_refused("--robot " + broken + " --gamma 1", "broken XML at line 2");
  expect_refused("--robot " + examples + "/arm3.urdf --tip-link gripper --gamma 1", "there is no link 'gripper'");
  expect_refused("--robot " + examples + "/arm3.urdf --base-link forearm --tip-link turret --gamma 1",
                 "no chain from 'forearm' down to 'turret'");
  expect_refused("--robot " + examples + "/pendubot.urdf --actuated 1,0,1 --gamma 1",
                 "--actuated: the chain has 2 joints; give one flag per joint, not 3");
  expect_refused("--robot " + examples + "/arm3.urdf --actuated 0,0,0 --gamma 1", "--actuated: at least one joint must be actuated");
  // A fraction is refused before the loader (which refuses 2), in the loader's words.
  expect_refused("--robot " + examples + "/arm3.urdf --actuated 1,0.5,1 --gamma 1", "--actuated: flag 2 = 0.5 must be 0 or 1");
  expect_refused("--robot " + examples + "/arm3.urdf --actuated 1,2,1 --gamma 1", "--actuated: flag 2 = 2 must be 0 or 1");
  expect_refused("--robot " + examples + "/panda.urdf --armature 0.1 --gamma 1",
                 "--armature: the chain has 7 joints; give one value per joint, not 1");
  expect_refused("--robot " + examples + "/arm3.urdf --armature -1,0,0 --gamma 1", "--armature: a1 = -1 must be >= 0");
  expect_refused("--robot " + examples + "/acrobot.json --armature 0.1 --gamma 1",
                 "--armature: the model has 2 joints; give one value per joint, not 1");
  expect_refused("--robot " + examples + "/pendubot.urdf --joint-limits c --gamma 1",
                 "--joint-limits: the chain has 2 joints; give one range per joint, not 1");
  expect_refused("--robot pendubot --actuated 1,0 --gamma 1", "apply to URDF robots only");
}

TEST(MonteCarloApp, ExitOneWhenTheCertificateIsViolated) {
  const AppRun r = run("monte-carlo", "--gamma 1 --L 0.01 --bounds numeric --trials 20 --horizon 3 --initial-errors practical");
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("CERTIFICATE VIOLATED"), std::string::npos);
}

// An output the app cannot write is refused before any work: on a six-joint arm the design would otherwise take two
// minutes and then fail. Nothing reaches stdout, so no design was printed.
TEST(OutputApps, AFileThatCannotBeWrittenIsRefusedBeforeAnyWork) {
  const std::string arm6 = "--robot " + std::string(OBSGAIN_EXAMPLES_DIR) + "/arm6.urdf --gamma 5 ";
  expect_refused(arm6 + "--json /nonexistent/dir/design.json",
                 "--json = '/nonexistent/dir/design.json': its directory '/nonexistent/dir' does not exist");
  expect_refused(arm6 + "--export-header /nonexistent/gains.hpp", "--export-header = '/nonexistent/gains.hpp'");
  expect_refused(arm6 + "--export-ros2 " + ::testing::TempDir(), "is a directory, not a file");
  // /proc takes no new file, though as root its directory passes every permission check (as another user it is named
  // not writable).
  expect_refused(arm6 + "--json /proc/obsgain_design.json", "--json = '/proc/obsgain_design.json'");
  expect_refused(arm6 + "--export-observer /nonexistent/observer.txt",
                 "--export-observer = '/nonexistent/observer.txt': its directory '/nonexistent' does not exist");
  // The checkpoint is opened with the request (in the library, the same message from Python).
  expect_refused(arm6 + "--checkpoint /nonexistent/search.json", "cannot write checkpoint '/nonexistent/search.json'");
  expect_refused("--theta 200 --csv /nonexistent/trials.csv", "--csv = '/nonexistent/trials.csv'", "monte-carlo");
  expect_refused("--theta 200 --trajectory /nonexistent/t.csv",
                 "--trajectory = '/nonexistent/t.csv': its directory '/nonexistent' does not exist", "monte-carlo");
  expect_refused("--theta 200 --json /nonexistent/mc.json", "--json = '/nonexistent/mc.json'", "monte-carlo");
  // verify-bounds' --out is a directory, created with its parents: the part of it that exists must be a directory.
  const std::string file = (std::filesystem::path(::testing::TempDir()) / "obsgain_not_a_directory").string();
  std::ofstream(file) << "x\n";
  const std::string pendubot = "--robot pendubot --gamma 1.27 ";
  expect_refused(pendubot + "--out " + file, "--out = '" + file + "' is not a directory", "verify-bounds");
  expect_refused(pendubot + "--out " + file + "/report",
                 "--out = '" + file + "/report': '" + file + "' is not a directory", "verify-bounds");
}

TEST(MonteCarloApp, RefusesBadInput) {
  expect_refused("--theta 200 --trials 0", "trials = 0", "monte-carlo");
  expect_refused("--theta 200 --trials 2.5", "trials = 2.5", "monte-carlo");
  expect_refused("--theta 200 --horizon -1", "horizon = -1", "monte-carlo");
  expect_refused("--theta 200 --threads -2", "threads = -2", "monte-carlo");
  expect_refused("--theta 200 --seed x", "seed = 'x'", "monte-carlo");
  expect_refused("--theta 200 --scenario moon", "scenario", "monte-carlo");
  expect_refused("--design /nonexistent/design.json", "/nonexistent/design.json", "monte-carlo");
  expect_refused("--theta 100 --certificate paper --bounds numeric", "certifies no exponential rate", "monte-carlo");
}

TEST(VerifyBoundsApp, WritesTheReportWithCertifiedBrackets) {
  const std::string out = ::testing::TempDir() + "/obsgain_verify";
  const AppRun r = run("verify-bounds", "--robot pendubot --gamma 1.27 --trials 20 --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = read_json(out + "/report.json");
  for (const auto& [name, reference] : {std::pair{"M0", 285.7398}, {"B", 0.4347667}, {"L_joint", 43.3475}}) {
    const double lower = report["certified"][name]["lower"], upper = report["certified"][name]["upper"];
    EXPECT_LE(lower, reference * (1 + 1e-6)) << name;
    EXPECT_GE(upper, reference * (1 - 1e-6)) << name;
    EXPECT_LE(upper - lower, 1e-6 * upper) << name;
  }
  EXPECT_TRUE(report["design_certified"].get<bool>());
  EXPECT_EQ(report["monte_carlo"]["trials"], 20);
  EXPECT_EQ(report["monte_carlo"]["envelope_violations"], 0);
  EXPECT_TRUE(report["comparison"].contains("paper"));
  const std::string html = read_text(out + "/report.html");
  EXPECT_GE(std::count(html.begin(), html.end(), '\n'), 50);
  // Every search reached its gap, and the bounds table says so row by row (M0, B, L_joint and L_T).
  const std::string reached_cell = "<td>gap reached</td><td>q = ";
  std::size_t reached = 0;
  for (auto at = html.find(reached_cell); at != std::string::npos; at = html.find(reached_cell, at + 1)) ++reached;
  EXPECT_EQ(reached, 4u);
  // The default design is the scaled one: the LMI line is its own check, not the tight certificate's, and the verdict
  // gives the gap of the constant it rests on.
  EXPECT_NE(html.find("The scaled certificate's LMI largest eigenvalue -"), std::string::npos);
  EXPECT_NE(html.find("relative gap of L_T, which the design uses, "), std::string::npos);
  // Four plots inline; nothing loaded from outside (the SVG namespace URIs load nothing).
  std::size_t svgs = 0;
  for (auto at = html.find("<svg"); at != std::string::npos; at = html.find("<svg", at + 1)) ++svgs;
  EXPECT_EQ(svgs, 4u);
  for (const char* external : {"src=\"http", "src='http", "href=\"http", "href='http", "<link", "<script"})
    EXPECT_EQ(html.find(external), std::string::npos) << external;
  for (const char* csv : {"bound_curves.csv", "paper_scenario.csv", "monte_carlo_errors.csv", "rate_vs_theta.csv"})
    EXPECT_FALSE(read_text(out + "/" + csv).empty()) << csv;
}

// The verdict gives the gap of the constant the design rests on, then the largest: on the two-link arm at this budget
// L_T wins the race within 2 % while L_joint stopped after its first share, and M0 (which only L_paper uses) has no
// finite upper end yet (a relative gap of 1, its limit). No warning of a wide bracket: the one used is narrow.
TEST(VerifyBoundsApp, TheVerdictGivesTheGapOfTheConstantTheDesignUses) {
  const std::string out = ::testing::TempDir() + "/obsgain_verify_gap";
  const AppRun r = run("verify-bounds", "--robot " + std::string(OBSGAIN_EXAMPLES_DIR) +
                                            "/two_link_arm.json --gamma 5 --bound-budget 0.0024 --trials 4 --quiet --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string html = read_text(out + "/report.html");
  // With the proof's price: the same certificate on L_T's attained value (Design::AtAttained).
  EXPECT_NE(html.find("relative gap of L_T, which the design uses, 2.0e-02 (on its attained value the same certificate "
                      "takes θ = 20.35907, this design 1.011 times that); largest relative gap 1.0e+00 (M0)."),
            std::string::npos);
  EXPECT_EQ(html.find("times the value attained"), std::string::npos);
  const nlohmann::json report = read_json(out + "/report.json");
  EXPECT_EQ(report["certificate"], "scaled");
  EXPECT_EQ(report["design"]["at_attained"]["constant"], "L_T");
  EXPECT_EQ(report["design"]["at_attained"]["certificate"], "scaled");
  EXPECT_EQ(report["design"]["at_attained"]["L"], report["certified"]["L_scaled"]["lower"]);
  const double theta = report["design"]["theta"], floor = report["design"]["at_attained"]["theta"];
  EXPECT_NEAR(theta / floor, 1.011, 5e-4);
  EXPECT_TRUE(report["design"]["other_at_attained"].is_null());  // L_joint's attained value does no better
}

// Where L_T's proof went less far the design rests on L_joint, and the verdict also names the scaled certificate on
// L_T's attained value, the numeric estimate's design: the Pendubot at 3 ms, whose L_joint bracket closes.
TEST(VerifyBoundsApp, TheVerdictNamesTheEstimatesCertificateWhereItsProofWentLessFar) {
  const std::string out = ::testing::TempDir() + "/obsgain_verify_other";
  const AppRun r = run("verify-bounds", "--gamma 1.27 --bound-budget 0.003 --trials 4 --quiet --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(read_text(out + "/report.html")
                .find("relative gap of L_joint, which the design uses, 3.7e-07 (on its attained value the same "
                      "certificate takes the same θ within 0.0001); on L_T's attained value the scaled certificate takes "
                      "θ = 33.03015, as the numeric estimate does (this design 1.988 times that)"),
            std::string::npos);
  const nlohmann::json report = read_json(out + "/report.json");
  EXPECT_EQ(report["certificate"], "tight");
  EXPECT_EQ(report["design"]["other_at_attained"]["constant"], "L_T");
  EXPECT_EQ(report["design"]["other_at_attained"]["certificate"], "scaled");
  EXPECT_EQ(report["design"]["at_attained"]["certificate"], "tight");
  EXPECT_EQ(report["design"]["other_at_attained"]["L"], report["certified"]["L_scaled"]["lower"]);
}

// Also: with --optimize-shape the report says how α was chosen, as the table does.
TEST(VerifyBoundsApp, WithoutGnuplotTheReportStillBuildsAndSaysWhy) {
  const std::string out = ::testing::TempDir() + "/obsgain_verify_noplot";
  const AppRun r = run("verify-bounds", "--gamma 1.27 --bounds numeric --optimize-shape --trials 4 --out " + out,
                       "PATH=/nonexistent");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string html = read_text(out + "/report.html");
  EXPECT_NE(html.find("Plots are missing: gnuplot is not installed"), std::string::npos);
  EXPECT_EQ(html.find("<svg"), std::string::npos);
  EXPECT_FALSE(read_text(out + "/bound_curves.csv").empty());
  std::array<char, 96> line{};
  std::snprintf(line.data(), line.size(), "shape optimised (beta = 1, minimise theta_star): alpha = %.7f",
                read_json(out + "/report.json")["design"]["alpha"].get<double>());
  EXPECT_NE(html.find(line.data()), std::string::npos) << line.data();
}

// Named, the scaled certificate keeps any similarity that lowers L_joint's estimate: on arm6 T lowers it by 2.8 %,
// below the 5 % a default design asks (BoundOptions::scaling_min_gain), so the default is tight and the named one is
// scaled, with a smaller θ and the envelope constant's factor cond(T) (1.282: T is the one of smallest cond within
// BoundOptions::scaling_slack of the lowest estimate). Where L_T's proof then ends above
// L_joint's (arm7 at a small budget), the named certificate is used as asked and the warning says so.
TEST(DesignGainsApp, ANamedScaledCertificateKeepsAnySimilarityThatLowersLJoint) {
  const std::string arm6 = std::string(OBSGAIN_EXAMPLES_DIR) + "/arm6.urdf";
  const AppRun named = run("design-gains", "--robot " + arm6 + " --gamma 5 --bounds numeric --certificate scaled --quiet --json");
  const AppRun unnamed = run("design-gains", "--robot " + arm6 + " --gamma 5 --bounds numeric --quiet --json");
  for (const AppRun* r : {&named, &unnamed}) ASSERT_EQ(r->exit_code, 0) << r->err;
  const nlohmann::json s = nlohmann::json::parse(named.out), t = nlohmann::json::parse(unnamed.out);
  EXPECT_EQ(s["certificate"], "scaled");
  EXPECT_EQ(t["certificate"], "tight");
  EXPECT_FALSE(t["bounds"].contains("L_scaled"));
  const double L_joint = s["bounds"]["L_joint"].get<double>(), L_T = s["bounds"]["L_scaled"].get<double>();
  EXPECT_DOUBLE_EQ(L_joint, t["bounds"]["L_joint"].get<double>());
  EXPECT_NEAR(L_T, 11.23111, 1e-5);  // estimates: L_joint 11.55118; at the lowest, 11.19913
  EXPECT_GT(L_T, 0.95 * L_joint);
  EXPECT_NEAR(s["design"]["theta"].get<double>(), 25.16408, 1e-5);
  EXPECT_DOUBLE_EQ(s["comparison"]["tight"]["theta"].get<double>(), t["design"]["theta"].get<double>());
  EXPECT_LT(s["design"]["theta"].get<double>(), 0.985 * t["design"]["theta"].get<double>());  // 25.16 against 25.62
  const auto T = s["bounds"]["scaling"].get<std::vector<std::vector<double>>>();
  ASSERT_EQ(T.size(), 6u);
  double largest = 0.0, smallest = 1e300;
  for (std::size_t i = 0; i < T.size(); ++i) {
    largest = std::max(largest, T[i][i]);
    smallest = std::min(smallest, T[i][i]);
  }
  EXPECT_NEAR(largest / smallest, 1.28197, 1e-4);
  // k: the tight certificate's P₂'s at this θ times cond(T), 42.68 against 33.95.
  EXPECT_NEAR(s["design"]["k"].get<double>(), 42.6759, 1e-3);
  EXPECT_LT(s["design"]["k"].get<double>(), 1.3 * t["design"]["k"].get<double>());

  const std::string arm7 = std::string(OBSGAIN_EXAMPLES_DIR) + "/arm7.urdf";
  const AppRun lost = run("design-gains", "--robot " + arm7 + " --gamma 5 --bound-budget 4 --certificate scaled --quiet --json");
  ASSERT_EQ(lost.exit_code, 0) << lost.err;
  const nlohmann::json l = nlohmann::json::parse(lost.out);
  EXPECT_EQ(l["certificate"], "scaled");
  EXPECT_GT(l["bounds"]["L_scaled"].get<double>(), l["bounds"]["L_joint"].get<double>());
  EXPECT_GT(l["design"]["theta"].get<double>(), l["comparison"]["tight"]["theta"].get<double>());
  const std::string warnings = l["warnings"].dump();
  EXPECT_NE(warnings.find("--certificate scaled: L_T = "), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("without --certificate the better of the two is chosen"), std::string::npos) << warnings;
}

// Above two joints, a proof stopped by --proof-budget falls back to the norm-bound certificate (on arm3 the scaled
// one) and says what would help; the work it spent is reported, and it is the budget's (counted work: the same
// number on every run).
TEST(DesignGainsApp, APolytopicProofPastItsBudgetFallsBackAndNamesTheBudget) {
  const std::string examples = OBSGAIN_EXAMPLES_DIR;
  const AppRun r = run("design-gains", "--robot " + examples +
                                           "/arm3.urdf --gamma 5 --certificate polytopic --proof-budget 0.5 --quiet --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["certificate"], "scaled");
  EXPECT_TRUE(j["certified"].get<bool>());
  EXPECT_EQ(j["polytope"]["method"], "search");
  EXPECT_GE(j["polytope"]["proof_work"].get<double>(), 0.5);
  EXPECT_LT(j["polytope"]["proof_work"].get<double>(), 1.0);  // 0.546: the round that crossed the budget ends
  const std::string warnings = j["warnings"].dump();
  EXPECT_NE(warnings.find("not proven within the proof budget of 0.5 s"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("a larger --proof-budget"), std::string::npos) << warnings;
  // The table does not print the unproven P's target rate as certified.
  const AppRun table = run("design-gains", "--robot " + examples +
                                               "/arm3.urdf --gamma 5 --certificate polytopic --proof-budget 0.5 --quiet");
  ASSERT_EQ(table.exit_code, 0) << table.err;
  const auto line = table.out.substr(table.out.find("gamma certified at theta"));
  EXPECT_EQ(line.substr(0, line.find('\n')).back(), '-') << line.substr(0, line.find('\n'));
}

// Above two joints the report's polytopic curve is the design's own search on sampled configurations, an estimate
// (it was the SDP on a merged polytope that could not be proven, and plotted 512 k1 at every θ). On arm3 at γ = 5
// the design's sampled θ* is 28.98 (docs/theory.md): the curve crosses the target between its points either side,
// rises with θ, and lies above the tight certificate's rate wherever the SDP found a P.
TEST(VerifyBoundsApp, ThreeJointPolytopicCurveIsTheDesignsSearch) {
  const std::string examples = OBSGAIN_EXAMPLES_DIR;
  const std::string out = ::testing::TempDir() + "/obsgain_verify_arm3_polytopic";
  const AppRun r = run("verify-bounds", "--robot " + examples + "/arm3.urdf --gamma 5 --certificate polytopic "
                                        "--trials 4 --horizon 0.3 --quiet --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = read_json(out + "/report.json");
  ASSERT_EQ(report["design"]["certificate"], "polytopic");
  // The verdict names what it rests on: the proof over the joint domain, not an L it does not use.
  const std::string html = read_text(out + "/report.html");
  EXPECT_NE(html.find("polytopic certificate (one full P, its LMI proven over the joint domain"), std::string::npos);
  EXPECT_EQ(html.find("polytopic certificate on L"), std::string::npos);
  const double alpha = report["design"]["alpha"].get<double>();
  std::istringstream csv(read_text(out + "/rate_vs_theta.csv"));
  std::string line;
  std::getline(csv, line);
  ASSERT_EQ(line, "theta,paper_gamma,tight_gamma,polytopic_gamma,scaled_gamma");
  double below = 0.0, above = 0.0, previous = -1e300;
  int points = 0;
  while (std::getline(csv, line)) {
    double theta = 0.0, paper = 0.0, tight = 0.0, polytopic = 0.0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf", &theta, &paper, &tight, &polytopic), 4) << line;
    if (std::isnan(polytopic)) continue;
    ++points;
    EXPECT_LT(polytopic, 0.5 * alpha * theta) << line;  // the linear part's own rate with Φ = 0
    EXPECT_GT(polytopic, tight) << line;
    EXPECT_GT(polytopic, previous) << line;
    previous = polytopic;
    if (theta < 28.98 && theta > 24.0) below = polytopic;
    if (theta > 28.98 && theta < 36.0) above = polytopic;
  }
  EXPECT_GE(points, 6);
  EXPECT_LT(below, 5.0);
  EXPECT_GT(above, 5.0);
}

TEST(VerifyBoundsApp, RefusesBadInput) {
  expect_refused("--gamma 1.27", "--out", "verify-bounds");
  expect_refused("--gamma -2 --out /tmp/x", "gamma = -2", "verify-bounds");
  // It computes its design: --design (monte-carlo's) is neither offered in its help nor accepted.
  expect_refused("--gamma 1.27 --design saved.json --out /tmp/x", "--design", "verify-bounds");
  EXPECT_EQ(run("verify-bounds", "--help").out.find("--design"), std::string::npos);
}

}  // namespace

namespace {

const std::string kDeployment = "--robot pendubot --gamma 1.27 --sample-period 0.001 --encoder-counts 4096 "
                                "--acceleration-bounds 200";

TEST(DeploymentApps, DesignGainsWritesTheDeploymentObjectAndExports) {
  const std::string header = ::testing::TempDir() + "/obsgain_gains.hpp", yaml = ::testing::TempDir() + "/obsgain_gains.yaml";
  const AppRun r = run("design-gains", kDeployment + " --objective velocity-error --json - --export-header " + header +
                                           " --export-ros2 " + yaml);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  const nlohmann::json& d = j.at("deployment");
  EXPECT_EQ(d.at("sample_period").get<double>(), 0.001);
  EXPECT_NEAR(d.at("encoder_resolution").at(1).get<double>(), 2.0 * M_PI / 4096, 1e-15);
  for (const char* key : {"ultimate_position_error", "ultimate_velocity_error"}) EXPECT_EQ(d.at(key).size(), 2u) << key;
  const double v_norm = d.at("ultimate_velocity_error_norm").get<double>();
  EXPECT_GT(v_norm, 0.6);  // the quantisation floor, certified: 0.652 rad/s (docs/theory.md, worked example)
  EXPECT_LT(v_norm, 0.7);
  EXPECT_GT(d.at("max_sample_period").get<double>(), 0.001);
  for (const char* key : {"k", "gamma", "offset", "level"}) EXPECT_GT(d.at("iss_envelope").at(key).get<double>(), 0.0) << key;
  EXPECT_TRUE(d.at("certified").get<bool>());
  EXPECT_GE(d.at("tradeoff").size(), 5u);
  const std::string h = read_text(header), y = read_text(yaml);
  EXPECT_NE(h.find("inline constexpr double k1 = "), std::string::npos);
  EXPECT_NE(h.find("inline constexpr double sample_period = 0.001;"), std::string::npos);
  EXPECT_NE(h.find("// CERTIFIED"), std::string::npos);
  EXPECT_NE(y.find("velocity_observer:\n  ros__parameters:\n"), std::string::npos);
  EXPECT_NE(y.find("    alpha: 1.0\n"), std::string::npos);  // a double, as ROS 2 declares it
  // The design file drives a sampled Monte Carlo with the same observer class.
  const std::string design = write_temp_file("deployed_design.json", r.out);
  const AppRun mc = run("monte-carlo", "--design " + design + " --trials 8 --horizon 0.3 --json -");
  ASSERT_EQ(mc.exit_code, 0) << mc.err;
  const nlohmann::json m = nlohmann::json::parse(mc.out);
  EXPECT_EQ(m.at("envelope_violations").get<int>(), 0);
  EXPECT_LE(m.at("sampled").at("worst_final_velocity_error").get<double>(), v_norm);
}

// The default rate design is the scaled certificate's (θ = 33.03); at 1 kHz its certified ultimate velocity error is
// 9.484 rad/s, within the default tolerance (min V = 10). Below that, at a tolerance of 8, the tight certificate's
// θ = 65.67 gives 6.97: the tight one is used, and a note says why.
TEST(DeploymentApps, TheRateDesignWithinTheToleranceIsPreferred) {
  const AppRun by_default = run("design-gains", kDeployment + " --json -");
  ASSERT_EQ(by_default.exit_code, 0) << by_default.err;
  const nlohmann::json d = nlohmann::json::parse(by_default.out);
  EXPECT_EQ(d["certificate"], "scaled");
  EXPECT_NEAR(d["deployment"]["ultimate_velocity_error_norm"].get<double>(), 9.484, 0.001);  // docs/theory.md
  const AppRun rate = run("design-gains", kDeployment + " --velocity-error-tolerance 8 --json -");
  ASSERT_EQ(rate.exit_code, 0) << rate.err;
  const nlohmann::json j = nlohmann::json::parse(rate.out);
  EXPECT_EQ(j["certificate"], "tight");
  EXPECT_NEAR(j["design"]["theta"].get<double>(), 65.67, 0.01);
  EXPECT_NEAR(j["deployment"]["ultimate_velocity_error_norm"].get<double>(), 6.974, 0.001);  // docs/theory.md
  EXPECT_NE(j["notes"].dump().find("the scaled certificate's θ = 33.0"), std::string::npos) << j["notes"].dump();
  // Named, the scaled certificate is what is asked for: refused, naming the limit.
  const AppRun scaled = run("design-gains", kDeployment + " --velocity-error-tolerance 8 --certificate scaled");
  EXPECT_EQ(scaled.exit_code, 1);
  EXPECT_NE(scaled.err.find("exceeds the tolerance"), std::string::npos) << scaled.err;
}

TEST(DeploymentApps, APeriodAboveTheLimitOrATolerancePastReachIsRefused) {
  // At 1 kHz no rate design certifies 5 rad/s (tight 6.97, scaled 9.48): exit 1, naming the limit.
  const std::string header = ::testing::TempDir() + "/obsgain_refused_gains.hpp";
  std::remove(header.c_str());
  const AppRun rate = run("design-gains", kDeployment + " --velocity-error-tolerance 5 --export-header " + header);
  EXPECT_EQ(rate.exit_code, 1);
  EXPECT_NE(rate.err.find("exceeds the tolerance"), std::string::npos) << rate.err;
  EXPECT_FALSE(std::filesystem::exists(header)) << "gains that fail the request are never exported";
  const AppRun slow = run("design-gains", "--robot pendubot --gamma 1.27 --sample-period 0.05 --encoder-counts 4096 "
                                          "--acceleration-bounds 200 --objective velocity-error");
  EXPECT_EQ(slow.exit_code, 1);
  EXPECT_NE(slow.err.find("largest sample period"), std::string::npos) << slow.err;
}

TEST(DeploymentApps, RefusesIncompleteOrBadDeployments) {
  expect_refused("--gamma 1.27 --sample-period 0.001", "--sample-period, --encoder-counts and --acceleration-bounds");
  expect_refused("--gamma 1.27 --objective velocity-error", "needs a deployment");
  expect_refused(kDeployment.substr(0, kDeployment.find("--gamma")) + "--theta 100 --sample-period 0.001 "
                 "--encoder-counts 4096 --acceleration-bounds 200 --objective velocity-error", "needs --gamma");
  expect_refused("--gamma 1.27 --sample-period 0 --encoder-counts 4096 --acceleration-bounds 200", "--sample-period = 0");
  expect_refused("--gamma 1.27 --sample-period 0.001 --encoder-counts 4096.5 --acceleration-bounds 200", "N1 = 4096.5");
  expect_refused("--gamma 1.27 --sample-period 0.001 --encoder-counts 4096,4096,4096 --acceleration-bounds 200",
                 "3 values for a robot of 2 joints");
  expect_refused("--gamma 1.27 --sample-period 0.001 --encoder-counts 4096 --acceleration-bounds -5", "A1 = -5");
  expect_refused("--design " + write_temp_file("empty_design.json", "{}") + " --sample-period 0.001",
                 "--sample-period cannot be given with it", "monte-carlo");
  expect_refused("--gamma 1.27 --certificate polytopic --polytope-cells 0", "--polytope-cells = 0");
}

// The polytopic certificate as a user asks for it: one full P, proven, then validated by simulation with that P.
TEST(PolytopicApps, PendubotDesignIsProvenAndPassesMonteCarlo) {
  const std::string design = ::testing::TempDir() + "/obsgain_polytopic_design.json";
  const AppRun d = run("design-gains", "--gamma 1.27 --certificate polytopic --json " + design);
  ASSERT_EQ(d.exit_code, 0) << d.err;
  const nlohmann::json j = read_json(design);
  EXPECT_EQ(j["certificate"], "polytopic");
  EXPECT_EQ(j["design"]["certificate"], "polytopic");
  EXPECT_TRUE(j["certified"].get<bool>());
  // Half the tight certificate's gain (65.65) for the same rate (docs/theory.md).
  const double theta = j["design"]["theta"].get<double>();
  EXPECT_LT(theta, 35.0);
  EXPECT_GT(theta, 19.4);  // the ceiling of any quadratic certificate (the worst frozen Φ)
  EXPECT_GT(j["comparison"]["tight"]["theta"].get<double>(), 65.0);
  const auto P = j["design"]["P"].get<std::vector<std::vector<double>>>();
  ASSERT_EQ(P.size(), 4u);
  EXPECT_NE(P[0][0], P[1][1]);  // a full P, not P₂ ⊗ I
  EXPECT_EQ(j["polytope"]["cells"], 32);
  const AppRun mc = run("monte-carlo", "--design " + design + " --trials 100 --seed 5 --json");
  ASSERT_EQ(mc.exit_code, 0) << mc.err;
  const nlohmann::json report = nlohmann::json::parse(mc.out);
  EXPECT_EQ(report["envelope_violations"], 0);
  EXPECT_EQ(report["lyapunov_violations"], 0);
  EXPECT_EQ(report["passed"], 100);
}

// Where the polytope cannot be proven (too few cells for M to be proven invertible), the better norm-bound
// certificate is used (on the Pendubot the scaled one: its L_T is below L_joint) and the warning says why. With
// --optimize-shape it is designed at its own best α: the same design as asking for it, not the tight certificate's α
// (the polytopic search's starting point) under the scaled certificate.
TEST(PolytopicApps, FallsBackToTheNormBoundCertificateAtItsOwnShapeAndSaysWhy) {
  // One cell is too wide to prove the Pendubot's M invertible: the polytope cannot be built.
  const std::string request = "--gamma 5 --optimize-shape --json";
  const AppRun fallen = run("design-gains", request + " --certificate polytopic --polytope-cells 1");
  const AppRun asked = run("design-gains", request + " --certificate scaled");
  for (const AppRun* r : {&fallen, &asked}) ASSERT_EQ(r->exit_code, 0) << r->err;
  const nlohmann::json f = nlohmann::json::parse(fallen.out), a = nlohmann::json::parse(asked.out);
  EXPECT_EQ(f["certificate"], "scaled");
  EXPECT_LT(f["bounds"]["L_scaled"].get<double>(), f["bounds"]["L_joint"].get<double>());
  EXPECT_TRUE(f["certified"].get<bool>());
  const std::string warnings = f["warnings"].dump();
  EXPECT_NE(warnings.find("the polytopic certificate failed (no proven polytope"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("the scaled certificate is used"), std::string::npos) << warnings;
  // The tight certificate's best α (the search's start), which the scaled certificate's differs from (L_T < L_joint).
  EXPECT_NE(warnings.find("not 1.28638, chosen for the polytopic certificate"), std::string::npos) << warnings;
  EXPECT_DOUBLE_EQ(f["design"]["alpha"].get<double>(), a["design"]["alpha"].get<double>());
  EXPECT_NEAR(a["design"]["alpha"].get<double>(), 1.34010, 1e-5);
  EXPECT_DOUBLE_EQ(f["design"]["theta"].get<double>(), a["design"]["theta"].get<double>());
}

}  // namespace

namespace {

// --checkpoint saves the certified searches; --resume takes the finished ones from the file (nothing is searched
// again: the same brackets, their recorded times included) and refuses a checkpoint of another request, a file
// that is not there, and both options at once. A search resumed mid-way: ArmBrackets.ResumedSearchesEndAs...
TEST(DesignGainsApp, CheckpointAndResume) {
  const std::string checkpoint = ::testing::TempDir() + "/pendubot_" + std::to_string(getpid()) + ".checkpoint";
  const AppRun first = run("design-gains", "--gamma 1.27 --json --checkpoint " + checkpoint);
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const AppRun again = run("design-gains", "--gamma 1.27 --json --resume " + checkpoint);
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const auto brackets = [](const AppRun& r) { return nlohmann::json::parse(r.out).at("bounds").at("brackets"); };
  EXPECT_EQ(brackets(first), brackets(again));
  EXPECT_GT(brackets(again).at("M0").at("seconds").get<double>(), 0.0);
  expect_refused("--gamma 1.27 --vmax 5,5 --resume " + checkpoint, "was saved for another request");
  expect_refused("--gamma 1.27 --resume " + checkpoint + ".missing", "cannot read checkpoint");
  expect_refused("--gamma 1.27 --checkpoint a --resume b", "give one of --checkpoint");
  std::remove(checkpoint.c_str());
}

}  // namespace
