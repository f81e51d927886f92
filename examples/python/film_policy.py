"""A multi-task policy written in Python: one MLP whose hidden layer each task scales and shifts (FiLM), h =
tanh(W1 s + b1) * (1 + gamma_k) + beta_k, action = W2 h + b2 (examples/plugin/film_policy.cpp is the same policy in
C++). Registered as method "film_mlp_py" when the file is imported or loaded as a config's plugin."""

import maps

WIDTH = 64


class FilmPolicy(maps.Policy):
    def __init__(self, shape, generator):
        super().__init__(shape)
        self.body = maps.nn.Linear(shape.observation_size, WIDTH, generator=generator)
        self.gamma = maps.nn.Parameter(maps.zeros([shape.num_tasks, WIDTH]), dtype="float32")
        self.beta = maps.nn.Parameter(maps.zeros([shape.num_tasks, WIDTH]), dtype="float32")
        self.head = maps.nn.Linear(WIDTH, shape.action_size, generator=generator)

    def act(self, observations, tasks):
        hidden = maps.tanh(self.body(observations))
        scale = self.gamma[list(tasks)] + 1.0
        shift = self.beta[list(tasks)]
        return self.head(hidden * scale + shift)


maps.register_method("film_mlp_py", FilmPolicy, "one MLP whose hidden layer each task scales and shifts (FiLM)")
