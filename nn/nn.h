#pragma once

// Umbrella header of the nn layer (namespaces maps::nn and maps::optim).
#include "autograd/autograd.h"
#include "nn/activation.h"
#include "nn/clip_grad.h"
#include "nn/functional.h"
#include "nn/init.h"
#include "nn/linear.h"
#include "nn/mlp.h"
#include "nn/module.h"
#include "nn/module_list.h"
#include "nn/optim/adam.h"
#include "nn/optim/optimizer.h"
#include "nn/optim/sgd.h"
#include "nn/parallel_linear.h"
#include "nn/sequential.h"
#include "nn/serialize.h"
