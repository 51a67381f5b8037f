// A bounded random-mutation fuzz of every reader of user files: JSON model files, saved design files and
// URDFs. Each mutant of a valid seed (bytes flipped, deleted, duplicated, numbers replaced by extreme ones,
// the text cut short) must load or be refused with an InputError naming the problem: never another exception,
// a crash (the suite also runs under AddressSanitizer), or a hang.
#include "test_files.hpp"
#include "json.hpp"
#include "obsgain/deployment/deployment.hpp"
#include "obsgain/report/report.hpp"
#include "obsgain/parsers/robots.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <random>
#include <sstream>

namespace {

using obsgain_test::read_text;
using obsgain_test::write_temp_file;

using obsgain_test::examples;

std::string mutate(std::string text, std::mt19937_64& rng) {
  static const std::vector<std::string> tokens = {"1e999", "-1e999", "nan", "0", "-1", "1e308", "\"", "<", ">", "}",
                                                  "]", ",", "0x10", "", "<joint name=\"j\" type=\"fixed\"/>"};
  const int edits = 1 + static_cast<int>(rng() % 4);
  for (int e = 0; e < edits && !text.empty(); ++e) {
    const std::size_t at = rng() % text.size();
    switch (rng() % 5) {
      case 0: text[at] = static_cast<char>(rng() % 128); break;
      case 1: text.erase(at, 1 + rng() % 16); break;
      case 2: text.insert(at, text.substr(rng() % text.size(), 1 + rng() % 32)); break;
      case 3: text.insert(at, tokens[rng() % tokens.size()]); break;
      default: text.resize(at); break;
    }
  }
  return text;
}

// Loads a mutant; returns false (and records why) if anything but success or an InputError happened.
template <class Load>
void expect_only_input_errors(const std::string& seed, const std::string& suffix, int mutants, Load&& load) {
  std::mt19937_64 rng(12345);
  const std::string path = ::testing::TempDir() + "/obsgain_fuzz" + suffix;
  int refused = 0, loaded = 0;
  for (int i = 0; i < mutants; ++i) {
    const std::string text = mutate(seed, rng);
    std::ofstream(path, std::ios::trunc) << text;
    try {
      load(path);
      ++loaded;
    } catch (const obsgain::InputError& e) {
      ++refused;
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << "one line: " << e.what();
      EXPECT_LT(std::string(e.what()).size(), 2000u) << "short: " << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "mutant " << i << " of " << suffix << " threw " << e.what() << "\n" << text.substr(0, 400);
    }
  }
  EXPECT_GT(refused, mutants / 4) << "the mutations should break most files";
  ::testing::Test::RecordProperty("loaded", loaded);
}

TEST(Fuzz, ModelFilesLoadOrAreRefused) {
  for (const char* file : {"pendubot.json", "two_link_arm.json"})
    expect_only_input_errors(read_text(examples + "/" + file), ".json", 600,
                             [](const std::string& path) { obsgain::load_robot({path}); });
}

TEST(Fuzz, UrdfsLoadOrAreRefused) {
  for (const char* file : {"arm3.urdf", "arm7.urdf"})
    expect_only_input_errors(read_text(examples + "/" + file), ".urdf", 600,
                             [](const std::string& path) { obsgain::load_robot({path}); });
}

TEST(Fuzz, DesignFilesLoadOrAreRefused) {
  obsgain::DesignOptions options;
  options.gamma = 1.27;
  options.bound_method = obsgain::BoundMethod::numeric;
  // With a deployment object, whose reader is the longest.
  obsgain::DeploymentOptions deployment;
  deployment.sample_period = 1e-3;
  deployment.encoder_resolution = Eigen::Vector2d::Constant(1.5e-3);
  deployment.acceleration_bounds = Eigen::Vector2d::Constant(200.0);
  const std::string seed = obsgain::to_json(obsgain::design_observer(obsgain::pendubot(), options, deployment)).dump(1);
  ASSERT_NE(seed.find("\"deployment\""), std::string::npos);
  expect_only_input_errors(seed, ".design.json", 600, [](const std::string& path) {
    std::ifstream file(path);
    nlohmann::json j;
    try {
      file >> j;
    } catch (const nlohmann::json::exception&) {
      throw obsgain::InputError("not JSON");  // as the app does before the reader (tested in test_apps)
    }
    obsgain::saved_design_from_json(j);
  });
}

}  // namespace
