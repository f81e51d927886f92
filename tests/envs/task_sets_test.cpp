#include "envs/task_sets.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "envs/half_cheetah.h"

namespace maps::envs {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

std::unique_ptr<HalfCheetahEnv> make_cheetah(const std::string& task) {
  std::unique_ptr<Env> env = make_env(task);
  auto* cheetah = dynamic_cast<HalfCheetahEnv*>(env.get());
  if (cheetah == nullptr) throw std::runtime_error(task + " is not a HalfCheetahEnv");
  env.release();
  return std::unique_ptr<HalfCheetahEnv>(cheetah);
}

const char* kBodies[7] = {"torso", "bthigh", "bshin", "bfoot", "fthigh", "fshin", "ffoot"};

TEST(TaskSets, NamesAndIndices) {
  EXPECT_THAT(task_set_names(), ElementsAre("gravity", "modified", "mt10"));
  EXPECT_THAT(task_names("mt10"), ElementsAre("mt10/reach", "mt10/push", "mt10/pick-place", "mt10/door-open",
                                              "mt10/drawer-open", "mt10/drawer-close", "mt10/button-press-topdown",
                                              "mt10/peg-insert-side", "mt10/window-open", "mt10/window-close"));
  EXPECT_THAT(task_names("gravity"),
              ElementsAre("gravity/0.5", "gravity/0.75", "gravity/1.0", "gravity/1.25", "gravity/1.5"));
  EXPECT_THAT(task_names("modified"),
              ElementsAre("modified/original", "modified/big_head", "modified/small_head", "modified/big_torso",
                          "modified/small_torso", "modified/big_thigh", "modified/small_thigh", "modified/big_leg",
                          "modified/small_leg", "modified/big_foot", "modified/small_foot"));
  for (const auto& set : task_set_names()) {
    const auto names = task_names(set);
    for (std::size_t i = 0; i < names.size(); ++i) {
      EXPECT_EQ(task_index(names[i]), static_cast<std::int64_t>(i));
      EXPECT_EQ(task_set_of(names[i]), set);
    }
  }
}

TEST(TaskSets, UnknownNamesListTheValidOnes) {
  EXPECT_THAT([] { make_env("gravity/2.0"); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
                  HasSubstr("gravity/2.0"), HasSubstr("gravity/0.5"), HasSubstr("modified/big_foot"))));
  EXPECT_THAT([] { task_names("mt50"); }, ::testing::ThrowsMessage<std::invalid_argument>(
                                              ::testing::AllOf(HasSubstr("mt50"), HasSubstr("gravity"))));
}

TEST(TaskSets, EveryCheetahTaskLoadsAndSteps) {  // MT10's tasks: mt10_test.cpp
  for (const std::string set : {"gravity", "modified"}) {
    for (const auto& task : task_names(set)) {
      SCOPED_TRACE(task);
      const auto env = make_env(task);
      EXPECT_EQ(env->spec().task, task);
      EXPECT_EQ(env->spec().task_index, task_index(task));
      Eigen::VectorXd obs = env->reset(0);
      ASSERT_EQ(obs.size(), 17);
      for (int t = 0; t < 20; ++t) {
        const StepResult r = env->step(Eigen::VectorXd::Constant(6, t % 2 == 0 ? 0.5 : -0.5));
        ASSERT_TRUE(r.observation.allFinite());
        ASSERT_TRUE(std::isfinite(r.reward));
        ASSERT_FALSE(r.done());
      }
    }
  }
}

TEST(TaskSets, GravityVectorPerTask) {
  const std::map<std::string, double> gravity = {{"gravity/0.5", -4.905},
                                                 {"gravity/0.75", -7.3575},
                                                 {"gravity/1.0", -9.81},
                                                 {"gravity/1.25", -12.2625},
                                                 {"gravity/1.5", -14.715}};
  const auto base = make_cheetah("modified/original");
  for (const auto& [task, g] : gravity) {
    SCOPED_TRACE(task);
    const auto env = make_cheetah(task);
    EXPECT_EQ(env->model()->opt.gravity[0], 0.0);
    EXPECT_EQ(env->model()->opt.gravity[1], 0.0);
    EXPECT_NEAR(env->model()->opt.gravity[2], g, 1e-12);
    // Gravity changes nothing else: masses and sizes are those of the original.
    for (int b = 0; b < env->model()->nbody; ++b) EXPECT_EQ(env->model()->body_mass[b], base->model()->body_mass[b]);
    for (int i = 0; i < 3 * env->model()->ngeom; ++i)
      EXPECT_EQ(env->model()->geom_size[i], base->model()->geom_size[i]);
  }
}

TEST(TaskSets, GravityReallyActs) {
  // Same seed, zero action: under weaker gravity the torso sinks less in the first steps.
  const auto light = make_env("gravity/0.5");
  const auto heavy = make_env("gravity/1.5");
  light->reset(9);
  heavy->reset(9);
  StepResult a, b;
  for (int t = 0; t < 3; ++t) {
    a = light->step(Eigen::VectorXd::Zero(6));
    b = heavy->step(Eigen::VectorXd::Zero(6));
  }
  EXPECT_GT(a.observation[0], b.observation[0]);  // rootz
}

// Compiled geom sizes (radius, half-length) per modified task: cheetah.md §2.2.
TEST(TaskSets, GeomSizesPerModifiedTask) {
  const std::map<std::string, std::pair<double, double>> base = {
      {"torso", {0.046, 0.5}},   {"head", {0.046, 0.15}},    {"bthigh", {0.046, 0.145}}, {"bshin", {0.046, 0.15}},
      {"bfoot", {0.046, 0.094}}, {"fthigh", {0.046, 0.133}}, {"fshin", {0.046, 0.106}},  {"ffoot", {0.046, 0.07}}};
  // The changed geoms of each task and their expected sizes; every other geom keeps its size.
  const std::map<std::string, std::map<std::string, std::pair<double, double>>> changed = {
      {"modified/original", {}},
      {"modified/big_torso", {{"torso", {0.0575, 0.5}}}},  // the fromto torso keeps its length
      {"modified/small_torso", {{"torso", {0.0345, 0.5}}}},
      {"modified/big_thigh", {{"bthigh", {0.0575, 0.18125}}, {"fthigh", {0.0575, 0.16625}}}},
      {"modified/small_thigh", {{"bthigh", {0.0345, 0.10875}}, {"fthigh", {0.0345, 0.09975}}}},
      {"modified/big_leg", {{"bshin", {0.0575, 0.1875}}, {"fshin", {0.0575, 0.1325}}}},
      {"modified/small_leg", {{"bshin", {0.0345, 0.1125}}, {"fshin", {0.0345, 0.0795}}}},
      {"modified/big_foot", {{"bfoot", {0.0575, 0.1175}}, {"ffoot", {0.0575, 0.0875}}}},
      {"modified/small_foot", {{"bfoot", {0.0345, 0.0705}}, {"ffoot", {0.0345, 0.0525}}}},
      {"modified/big_head", {{"head", {0.0575, 0.1875}}}},
      {"modified/small_head", {{"head", {0.0345, 0.1125}}}},
  };
  ASSERT_EQ(changed.size(), task_names("modified").size());
  for (const auto& [task, sizes] : changed) {
    SCOPED_TRACE(task);
    const auto env = make_cheetah(task);
    const mjModel* m = env->model();
    EXPECT_NEAR(m->opt.gravity[2], -9.81, 1e-12);
    for (const auto& [geom, size] : base) {
      const auto it = sizes.find(geom);
      const auto expected = it == sizes.end() ? size : it->second;
      const int g = mj_name2id(m, mjOBJ_GEOM, geom.c_str());
      ASSERT_GE(g, 0) << geom;
      EXPECT_NEAR(m->geom_size[3 * g], expected.first, 1e-12) << geom;
      EXPECT_NEAR(m->geom_size[3 * g + 1], expected.second, 1e-12) << geom;
    }
    // Positions of geoms and bodies are untouched by a size change.
    const auto original = make_cheetah("modified/original");
    for (int i = 0; i < 3 * m->ngeom; ++i) EXPECT_EQ(m->geom_pos[i], original->model()->geom_pos[i]);
    for (int i = 0; i < 3 * m->nbody; ++i) EXPECT_EQ(m->body_pos[i], original->model()->body_pos[i]);
  }
}

// Body masses (kg) measured by the reference on the generated XMLs in MuJoCo 2.2.2, cheetah.md §2.2.
TEST(TaskSets, BodyMassesPerModifiedTask) {
  const std::map<std::string, std::vector<double>> masses = {
      {"modified/original", {6.2502, 1.5435, 1.5874, 1.0954, 1.4381, 1.2008, 0.8845}},
      {"modified/big_torso", {7.5141, 1.2918, 1.3286, 0.9168, 1.2035, 1.0050, 0.7403}},
      {"modified/small_torso", {4.8995, 1.8125, 1.8641, 1.2863, 1.6887, 1.4101, 1.0387}},
      {"modified/big_thigh", {5.1956, 2.5060, 1.3196, 0.9106, 2.3348, 0.9982, 0.7353}},
      {"modified/small_thigh", {7.1278, 0.7426, 1.8103, 1.2492, 0.6919, 1.3694, 1.0087}},
      {"modified/big_leg", {5.2530, 1.2973, 2.6058, 0.9206, 1.2086, 1.9712, 0.7434}},
      {"modified/small_leg", {7.0635, 1.7444, 0.7568, 1.2379, 1.6252, 0.5725, 0.9996}},
      {"modified/big_foot", {5.5078, 1.3602, 1.3989, 1.8853, 1.2673, 1.0582, 1.5224}},
      {"modified/small_foot", {6.8067, 1.6809, 1.7288, 0.5033, 1.5661, 1.3078, 0.4064}},
      {"modified/big_head", {7.0061, 1.3930, 1.4326, 0.9886, 1.2978, 1.0837, 0.7982}},
      {"modified/small_head", {5.7065, 1.6518, 1.6988, 1.1722, 1.5390, 1.2851, 0.9466}},
  };
  ASSERT_EQ(masses.size(), task_names("modified").size());
  for (const auto& [task, expected] : masses) {
    SCOPED_TRACE(task);
    const auto env = make_cheetah(task);
    const mjModel* m = env->model();
    double total = 0.0;
    for (int i = 0; i < 7; ++i) {
      const int b = mj_name2id(m, mjOBJ_BODY, kBodies[i]);
      EXPECT_NEAR(m->body_mass[b], expected[static_cast<std::size_t>(i)], 1e-4) << kBodies[i];
      total += m->body_mass[b];
    }
    EXPECT_NEAR(total, 14.0, 1e-9);
  }
}

}  // namespace
}  // namespace maps::envs
