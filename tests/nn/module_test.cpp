#include <cmath>
#include <memory>

#include "nn_test_util.h"

namespace nntest {
namespace {

// Exposes the protected registration API so the tests can call it directly.
class Bag : public nn::Module {
 public:
  Bag() : Module("Bag") {}
  using Module::register_buffer;
  using Module::register_module;
  using Module::register_parameter;

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<Bag>(*this); }
};

// Two linears and a buffer: parameters fc1.weight, fc1.bias, fc2.weight, fc2.bias; buffer "scale".
class TwoLayer : public nn::UnaryModule {
 public:
  explicit TwoLayer(ag::Generator& gen) : UnaryModule("TwoLayer") {
    scale_ = register_buffer("scale", ag::full({3}, 2.0));
    fc1_ = register_module("fc1", std::make_shared<nn::Linear>(2, 3, gen));
    fc2_ = register_module("fc2", std::make_shared<nn::Linear>(3, 1, gen));
  }
  Tensor forward(const Tensor& x) override {
    return child_at<nn::Linear>(fc2_).forward(ag::tanh(child_at<nn::Linear>(fc1_).forward(x)) * buffer_at(scale_));
  }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<TwoLayer>(*this); }

 private:
  std::size_t scale_, fc1_, fc2_;
};

TEST(Module, DottedNamesInInsertionOrder) {
  ag::Generator gen(1);
  auto outer = std::make_shared<Bag>();
  outer->register_parameter("alpha", ag::zeros({2}));
  auto layers = std::make_shared<nn::ModuleList>();
  layers->push_back(std::make_shared<nn::Linear>(2, 3, gen));
  layers->push_back(std::make_shared<nn::Linear>(3, 4, gen, /*bias=*/false));
  outer->register_module("layers", layers);
  outer->register_buffer("count", ag::zeros({1}));
  EXPECT_THAT(names_of(outer->named_parameters()),
              ::testing::ElementsAre("alpha", "layers.0.weight", "layers.0.bias", "layers.1.weight"));
  EXPECT_THAT(names_of(outer->named_parameters(/*recurse=*/false)), ::testing::ElementsAre("alpha"));
  EXPECT_THAT(names_of(outer->named_buffers()), ::testing::ElementsAre("count"));
  EXPECT_THAT(names_of(outer->state_dict()),
              ::testing::ElementsAre("alpha", "count", "layers.0.weight", "layers.0.bias", "layers.1.weight"));
  EXPECT_EQ(outer->parameters().size(), 4u);
  EXPECT_EQ(outer->children().size(), 1u);
  EXPECT_EQ(outer->parameter_count(), 2 + 6 + 3 + 12);
  EXPECT_EQ(outer->parameter("layers.1.weight").shape(), (Shape{4, 3}));
  for (const auto& p : outer->parameters()) EXPECT_TRUE(p.requires_grad());
  for (const auto& b : outer->buffers()) EXPECT_FALSE(b.requires_grad());
}

TEST(Module, RegistrationErrorsNameTheName) {
  Bag bag;
  EXPECT_THAT(error_of([&] { bag.register_parameter("", ag::zeros({1})); }), HasSubstr("must not be empty"));
  EXPECT_THAT(error_of([&] { bag.register_parameter("a.b", ag::zeros({1})); }),
              ::testing::AllOf(HasSubstr("\"a.b\""), HasSubstr("must not contain '.'")));
  EXPECT_THAT(error_of([&] { bag.register_buffer("x.y", ag::zeros({1})); }), HasSubstr("\"x.y\""));
  EXPECT_THAT(error_of([&] { bag.register_module("m.n", std::make_shared<Bag>()); }), HasSubstr("\"m.n\""));
  EXPECT_THAT(error_of([&] { bag.register_module("", std::make_shared<Bag>()); }), HasSubstr("must not be empty"));
  bag.register_parameter("w", ag::zeros({1}));
  EXPECT_THAT(error_of([&] { bag.register_buffer("w", ag::zeros({1})); }),
              ::testing::AllOf(HasSubstr("\"w\""), HasSubstr("already used")));
  EXPECT_THAT(error_of([&] { bag.register_module("w", std::make_shared<Bag>()); }), HasSubstr("already used"));
  EXPECT_THAT(error_of([&] { bag.register_parameter("u", Tensor()); }), HasSubstr("undefined"));
  EXPECT_THAT(error_of([&] { bag.register_module("c", nullptr); }), HasSubstr("null"));
  Tensor leaf = ag::ones({2}).requires_grad_();
  EXPECT_THAT(error_of([&] { bag.register_parameter("nonleaf", leaf * 2.0); }), HasSubstr("leaf"));
  EXPECT_THAT(error_of([&] { (void)bag.parameter("nope"); }),
              ::testing::AllOf(HasSubstr("\"nope\""), HasSubstr("parameters are: w")));
  bag.register_parameter("frozen", ag::zeros({1}), /*requires_grad=*/false);
  EXPECT_FALSE(bag.parameter("frozen").requires_grad());
}

TEST(Module, TrainEvalRecurses) {
  ag::Generator gen(2);
  TwoLayer m(gen);
  EXPECT_TRUE(m.is_training());
  m.eval();
  EXPECT_FALSE(m.is_training());
  for (const auto& c : m.children()) EXPECT_FALSE(c->is_training());
  m.train();
  for (const auto& c : m.children()) EXPECT_TRUE(c->is_training());
}

TEST(Module, ZeroGradSetsGradsUndefined) {
  ag::Generator gen(3);
  TwoLayer m(gen);
  ag::sum(m.forward(ag::ones({4, 2}))).backward();
  for (const auto& p : m.parameters()) EXPECT_TRUE(p.grad().defined());
  m.zero_grad();
  for (const auto& p : m.parameters()) EXPECT_FALSE(p.grad().defined());
}

TEST(Module, StateDictRoundTripAndSharing) {
  ag::Generator gen_a(4), gen_b(5);
  TwoLayer a(gen_a), b(gen_b);
  const Tensor x = tensor({0.1, -0.2, 0.3, 0.4}, {2, 2}, Dtype::Float32);
  EXPECT_GT(max_abs_diff(a.forward(x), b.forward(x)), 0.0);
  b.load_state_dict(a.state_dict());
  EXPECT_EQ(max_abs_diff(a.forward(x), b.forward(x)), 0.0);
  // state_dict tensors share storage with the module but are detached.
  auto state = a.state_dict();
  ASSERT_EQ(state[1].name, "fc1.weight");
  EXPECT_FALSE(state[1].tensor.requires_grad());
  EXPECT_EQ(state[1].tensor.data<float>(), a.parameter("fc1.weight").data<float>());
}

TEST(Module, LoadStateDictListsEveryProblem) {
  ag::Generator gen(6);
  TwoLayer m(gen);
  const auto before = m.state_dict()[1].tensor.to_vector();
  auto state = m.state_dict();
  // fc1.weight gets the wrong shape, fc2.bias is dropped, "extra" is added, "scale" gets the wrong dtype.
  for (auto& e : state) {
    if (e.name == "fc1.weight") e.tensor = ag::zeros({2, 3});
    if (e.name == "scale") e.tensor = ag::zeros({3}, Dtype::Float64);
  }
  std::erase_if(state, [](const nn::NamedTensor& e) { return e.name == "fc2.bias"; });
  state.push_back({"extra", ag::zeros({1})});
  const std::string msg = error_of([&] { m.load_state_dict(state); });
  EXPECT_THAT(msg, HasSubstr("Missing: fc2.bias"));
  EXPECT_THAT(msg, HasSubstr("Unexpected: extra"));
  EXPECT_THAT(msg, HasSubstr("fc1.weight (expected [3, 2] float32, got [2, 3] float32)"));
  EXPECT_THAT(msg, HasSubstr("scale (expected [3] float32, got [3] float64)"));
  // Nothing was copied.
  EXPECT_EQ(m.state_dict()[1].tensor.to_vector(), before);
}

// A state from a file may hold a NaN or an infinity: refused by name, the module left as it was.
TEST(Module, LoadStateDictRefusesValuesThatAreNotFinite) {
  ag::Generator gen(6);
  TwoLayer m(gen);
  const auto before = m.state_dict()[1].tensor.to_vector();
  for (const double bad : {std::nan(""), double(INFINITY), -double(INFINITY)}) {
    auto state = m.state_dict();
    for (auto& e : state)
      if (e.name == "fc1.bias") {
        e.tensor = e.tensor.detach().clone();
        e.tensor.data<float>()[1] = static_cast<float>(bad);
      }
    EXPECT_THAT(error_of([&] { m.load_state_dict(state); }), HasSubstr("Not finite: fc1.bias (entry 1)")) << bad;
  }
  EXPECT_EQ(m.state_dict()[1].tensor.to_vector(), before);
}

TEST(Module, ToDtypeConvertsParametersAndBuffers) {
  ag::Generator gen(7);
  TwoLayer m(gen);
  const auto w = m.parameter("fc1.weight").to_vector();
  m.to(Dtype::Float64);
  for (const auto& e : m.state_dict()) EXPECT_EQ(e.tensor.dtype(), Dtype::Float64) << e.name;
  for (const auto& p : m.parameters()) {
    EXPECT_TRUE(p.is_leaf());
    EXPECT_TRUE(p.requires_grad());
  }
  EXPECT_EQ(m.parameter("fc1.weight").to_vector(), w);  // float -> double is exact
  EXPECT_EQ(m.forward(ag::ones({1, 2}, Dtype::Float64)).dtype(), Dtype::Float64);
}

TEST(Module, CloneIsDeepAndIndependent) {
  ag::Generator gen(8);
  auto m = std::make_shared<TwoLayer>(gen);
  auto copy = nn::clone(m);
  const Tensor x = ag::ones({2, 2});
  EXPECT_EQ(max_abs_diff(m->forward(x), copy->forward(x)), 0.0);
  for (const auto& p : copy->parameters()) {
    EXPECT_TRUE(p.is_leaf());
    EXPECT_TRUE(p.requires_grad());
  }
  // Different storage: changing the copy leaves the original alone, and grads stay separate.
  Tensor w = copy->parameter("fc1.weight");
  w.fill_(0.0);
  EXPECT_NE(m->parameter("fc1.weight").to_vector(), w.to_vector());
  ag::sum(copy->forward(x)).backward();
  for (const auto& p : m->parameters()) EXPECT_FALSE(p.grad().defined());
  // The buffer was copied too.
  Tensor scale = copy->named_buffers()[0].tensor;
  EXPECT_NE(scale.data<float>(), m->named_buffers()[0].tensor.data<float>());
}

TEST(Module, ReplaceParameterIsUsedByForward) {
  ag::Generator gen(9);
  nn::Linear lin(2, 1, gen);
  lin.to(Dtype::Float64);
  const Tensor w = lin.weight();
  Tensor adapted = w * 2.0;  // a non-leaf
  lin.replace_parameter("weight", adapted);
  EXPECT_FALSE(lin.weight().is_leaf());
  const Tensor x = tensor({1.0, 1.0}, {1, 2});
  const double expected = 2.0 * (w.at(0) + w.at(1)) + lin.bias().at(0);
  EXPECT_NEAR(lin.forward(x).item(), expected, 1e-12);
  // The gradient flows back to the original leaf through the replaced slot.
  ag::sum(lin.forward(x)).backward();
  EXPECT_NEAR(w.grad().at(0), 2.0, 1e-12);
  EXPECT_THAT(error_of([&] {
                lin.replace_parameter("weight", ag::zeros({2, 1}, Dtype::Float64));
              }),
              ::testing::AllOf(HasSubstr("\"weight\""), HasSubstr("expected [1, 2] float64, got [2, 1] float64")));
  EXPECT_THAT(error_of([&] { lin.replace_parameter("missing", ag::zeros({1}, Dtype::Float64)); }),
              HasSubstr("no parameter named \"missing\""));
}

TEST(Module, CloneSharingParametersLeavesOriginalUntouched) {
  ag::Generator gen(10);
  auto m = std::make_shared<TwoLayer>(gen);
  auto learner = nn::clone_sharing_parameters(m);
  EXPECT_EQ(learner->parameter("fc1.weight").impl(), m->parameter("fc1.weight").impl());
  learner->replace_parameter("fc1.weight", m->parameter("fc1.weight") * 0.5);
  EXPECT_TRUE(m->parameter("fc1.weight").is_leaf());
  EXPECT_FALSE(learner->parameter("fc1.weight").is_leaf());
}

}  // namespace
}  // namespace nntest
