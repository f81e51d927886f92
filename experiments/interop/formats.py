#!/usr/bin/python3
"""Demo files to and from the formats other tools read (issue 16, item 2); `maps data export|import` runs this.

    formats.py export --format d4rl|minari|robomimic IN.h5 OUT [--dataset-id ID]
    formats.py import --format d4rl|minari|robomimic IN OUT.h5 [--task-set NAME] [--obs-keys K,...]

IN.h5 / OUT.h5 are this project's demo files (format 2, docs/datasets.md). What each format keeps and drops is in
docs/interop.md. Every file written here goes to a temporary in the same folder first and is renamed over OUT, so a
failed or killed conversion leaves no half-written file. Every HDF5 file is read from itself alone: one with an
external link, external raw storage, a virtual dataset, a user-defined link, a soft link that does not resolve or a
dataset stored through a filter HDF5 does not build in (a plugin's) is refused before anything is read (open_hdf5).
Errors name the file, the object and what was expected, and exit with status 1."""
import argparse
import json
import os
import pathlib
import sys

# libhdf5 loads no filter plugin in this process (read when h5py starts the library): a file from elsewhere names the
# filters its data needs, and would otherwise choose a shared object from HDF5_PLUGIN_PATH to be loaded.
# check_self_contained refuses such a dataset by name; this keeps a read it misses from loading code.
os.environ["HDF5_PLUGIN_PRELOAD"] = "::"

import h5py  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "process"))
import json_input  # noqa: E402

FORMAT_VERSION = 2
OBS_KEY = "flat"


class FormatError(Exception):
    """Bad input: the message names the file and what is wrong."""


# ----- this project's demo files ---------------------------------------------------------------------------------


def read_maps(path):
    """A demo file as a dict: file attributes, episodes (each a dict of arrays and attributes) and the masks."""
    f = open_hdf5(path)
    with f:
        if "data" not in f:
            raise FormatError(f"{path}: no group 'data' (not a demo file of this project)")
        data = f["data"]
        version = int(data.attrs.get("format_version", -1))
        if version != FORMAT_VERSION:
            raise FormatError(
                f"{path}: format_version {version}; export needs format {FORMAT_VERSION} (its next_obs and episode "
                f"ends). Collect it again with its own command: {text(data.attrs.get('creation_command', ''))}")
        out = {key: text(data.attrs[key]) for key in ("task_set", "env_version", "creation_command", "extra_json")}
        out["task_names"] = [text(name) for name in data.attrs["task_names"]]
        episodes = []
        for i in range(int(data.attrs["num_demos"])):
            group = data[f"demo_{i}"]
            episodes.append({
                "obs": group[f"obs/{OBS_KEY}"][()], "next_obs": group[f"next_obs/{OBS_KEY}"][()],
                "actions": group["actions"][()], "rewards": group["rewards"][()],
                "task_index": int(group.attrs["task_index"]), "seed": int(group.attrs["seed"]),
                "return": float(group.attrs["return"]), "success": int(group.attrs["success"]),
                "end": text(group.attrs["episode_end"])})
        out["episodes"] = episodes
        out["train"] = [int(text(name)[5:]) for name in f["mask/train"][()]]
        out["valid"] = [int(text(name)[5:]) for name in f["mask/valid"][()]]
    return out


def write_maps(path, demos):
    """Writes demos (as read_maps gives them) as a format 2 demo file."""
    def write(f):
        data = f.create_group("data")
        string = h5py.string_dtype("utf-8")
        data.attrs.create("format_version", FORMAT_VERSION, dtype="<i8")
        data.attrs["total"] = np.int64(sum(len(e["actions"]) for e in demos["episodes"]))
        # As envs/demo_file/writer.cpp writes it (nlohmann::json's dump: sorted keys, no spaces), so that the bytes agree.
        data.attrs["env_args"] = json.dumps({"env_name": "maps/" + demos["task_set"], "type": 2, "env_kwargs": {
            "task_set": demos["task_set"], "task_names": demos["task_names"], "env_version": demos["env_version"]}},
            sort_keys=True, separators=(",", ":"), ensure_ascii=False)
        for key in ("task_set", "env_version", "creation_command", "extra_json"):
            data.attrs.create(key, demos[key], dtype=string)
        data.attrs.create("task_names", demos["task_names"], dtype=string)
        data.attrs["num_demos"] = np.int64(len(demos["episodes"]))
        for i, e in enumerate(demos["episodes"]):
            group = data.create_group(f"demo_{i}")
            group.create_dataset(f"obs/{OBS_KEY}", data=np.asarray(e["obs"], dtype="<f8"))
            group.create_dataset(f"next_obs/{OBS_KEY}", data=np.asarray(e["next_obs"], dtype="<f8"))
            group.create_dataset("actions", data=np.asarray(e["actions"], dtype="<f8"))
            group.create_dataset("rewards", data=np.asarray(e["rewards"], dtype="<f8"))
            dones = np.zeros(len(e["actions"]), dtype="u1")
            dones[-1] = 1
            group.create_dataset("dones", data=dones)
            group.attrs["num_samples"] = np.int64(len(e["actions"]))
            group.attrs.create("task", demos["task_names"][e["task_index"]], dtype=string)
            group.attrs["task_index"] = np.int64(e["task_index"])
            group.attrs["return"] = np.float64(e["return"])
            group.attrs["success"] = np.uint8(e["success"])
            group.attrs["seed"] = np.uint64(e["seed"])
            group.attrs.create("episode_end", e["end"], dtype=string)
        for key in ("train", "valid"):
            names = [f"demo_{i}".encode() for i in demos[key]]
            f.create_dataset(f"mask/{key}", data=np.array(names, dtype="S") if names else np.zeros(0, dtype="S1"))
    write_atomically(path, write)


# ----- D4RL ------------------------------------------------------------------------------------------------------


def export_d4rl(demos, out):
    """D4RL's flat arrays (observations, actions, rewards, terminals, timeouts, next_observations), the task index
    per step in infos/task_index, and what D4RL has no place for under metadata/maps/. float64 kept (D4RL's own
    files are float32; its loader does not check the type), so that an import gives back the same bits."""
    episodes = demos["episodes"]

    def flags(kind):  # set at an episode's last step when it ended that way
        return np.concatenate([(np.arange(len(e["actions"])) == len(e["actions"]) - 1) & (e["end"] == kind)
                               for e in episodes])

    def write(f):
        f.create_dataset("observations", data=np.concatenate([e["obs"] for e in episodes]))
        f.create_dataset("next_observations", data=np.concatenate([e["next_obs"] for e in episodes]))
        f.create_dataset("actions", data=np.concatenate([e["actions"] for e in episodes]))
        f.create_dataset("rewards", data=np.concatenate([e["rewards"] for e in episodes]))
        f.create_dataset("terminals", data=flags("terminated"))
        f.create_dataset("timeouts", data=flags("truncated"))
        f.create_dataset("infos/task_index",
                         data=np.concatenate([np.full(len(e["actions"]), e["task_index"], dtype="<i8")
                                              for e in episodes]))
        meta = f.create_group("metadata/maps")
        meta["format_version"] = np.int64(FORMAT_VERSION)
        for key in ("task_set", "env_version", "creation_command", "extra_json"):
            meta[key] = np.bytes_(demos[key].encode())
        meta["task_names"] = np.array([name.encode() for name in demos["task_names"]], dtype="S")
        meta["episode_seed"] = np.array([e["seed"] for e in episodes], dtype="<u8")
        meta["episode_return"] = np.array([e["return"] for e in episodes], dtype="<f8")
        meta["episode_success"] = np.array([e["success"] for e in episodes], dtype="u1")
        split = np.full(len(episodes), b"", dtype="S5")
        split[demos["train"]] = b"train"
        split[demos["valid"]] = b"valid"
        meta["episode_split"] = split
    write_atomically(out, write)


def import_d4rl(path, task_set=None):
    """A D4RL file (this project's export or any other): episodes split where terminals or timeouts are set.
    Without metadata/maps (a file made elsewhere): one task unless infos/task_index says more, seeds are episode
    numbers, success 0, the split the last 30% of each task's episodes; without next_observations an episode's
    final observation is unknown, and its last observation stands in for it (said in extra_json)."""
    f = open_hdf5(path)
    with f:
        for key in ("observations", "actions", "rewards", "terminals"):
            if key not in f:
                raise FormatError(f"{path}: missing dataset '{key}' (D4RL requires observations, actions, rewards, "
                                  f"terminals)")
        obs = numeric(f, path, "observations", 2)
        n = len(obs)
        actions = numeric(f, path, "actions", 2, n)
        rewards = numeric(f, path, "rewards", 1, n, squeeze=True)
        terminals = flag_array(f, path, "terminals", n)
        timeouts = flag_array(f, path, "timeouts", n) if "timeouts" in f else np.zeros(n, dtype=bool)
        next_obs = numeric(f, path, "next_observations", 2, n) if "next_observations" in f else None
        if next_obs is not None and next_obs.shape[1] != obs.shape[1]:
            raise FormatError(f"{path}: next_observations has {next_obs.shape[1]} columns, observations "
                              f"{obs.shape[1]}")
        task_index = (np.asarray(f["infos/task_index"][()]).astype(np.int64) if "infos/task_index" in f
                      else np.zeros(n, dtype=np.int64))
        if task_index.shape != (n,):
            raise FormatError(f"{path}: infos/task_index has shape {task_index.shape}, expected ({n},)")
        meta = f["metadata/maps"] if "metadata/maps" in f else None
        if n == 0:
            raise FormatError(f"{path}: observations has no rows")
        ends = np.flatnonzero(terminals | timeouts)
        if len(ends) == 0 or ends[-1] != n - 1:
            ends = np.append(ends, n - 1)  # an unfinished last episode: cut at the file's end, as truncated
        starts = np.concatenate([[0], ends[:-1] + 1])
        episodes = []
        for start, end in zip(starts, ends):
            rows = slice(start, end + 1)
            if np.any(task_index[rows] != task_index[start]):
                raise FormatError(f"{path}: infos/task_index changes inside the episode of rows {start}..{end}")
            ep_obs = obs[rows]
            if next_obs is not None:
                ep_next = next_obs[rows]
                if not np.array_equal(ep_next[:-1], ep_obs[1:]):
                    raise FormatError(f"{path}: next_observations of rows {start}..{end - 1} is not observations one "
                                      f"row on: the episodes are not where terminals and timeouts put them")
            else:
                ep_next = np.concatenate([ep_obs[1:], ep_obs[-1:]])
            episodes.append({"obs": ep_obs, "next_obs": ep_next, "actions": actions[rows], "rewards": rewards[rows],
                             "task_index": int(task_index[start]), "seed": len(episodes),
                             "return": float(np.sum(rewards[rows])), "success": 0,
                             "end": "terminated" if terminals[end] else "truncated"})
        demos = {"episodes": episodes}
        if meta is not None:
            try:
                for key in ("task_set", "env_version", "creation_command", "extra_json"):
                    demos[key] = text(meta[key][()])
                demos["task_names"] = [text(name) for name in meta["task_names"][()]]
                seeds, returns = meta["episode_seed"][()], meta["episode_return"][()]
                success, split = meta["episode_success"][()], meta["episode_split"][()]
            except KeyError as e:
                raise FormatError(f"{path}: metadata/maps is missing {e}")
            if not len(seeds) == len(returns) == len(success) == len(split) == len(episodes):
                raise FormatError(f"{path}: metadata/maps describes {len(seeds)} episodes, terminals and timeouts "
                                  f"give {len(episodes)}")
            for e, seed, ret, ok in zip(episodes, seeds, returns, success):
                e.update(seed=int(seed), success=int(ok))
                e["return"] = float(ret)
            demos["train"] = [i for i, s in enumerate(split) if s == b"train"]
            demos["valid"] = [i for i, s in enumerate(split) if s == b"valid"]
        else:
            tasks = int(task_index.max()) + 1
            stem = pathlib.Path(path).stem
            demos.update(task_set=task_set or stem, task_names=[f"{task_set or stem}/{k}" for k in range(tasks)],
                         env_version="unknown (imported from D4RL)", creation_command="",
                         extra_json=json.dumps({"imported_from": str(path), "format": "d4rl",
                                                "final_obs": "next_observations" if next_obs is not None
                                                else "the last observation repeated (no next_observations)"}))
            demos["train"], demos["valid"] = split_by_task(episodes)
        if task_set:
            demos["task_set"] = task_set
        check_task_indices(path, demos)
        return demos


# ----- Minari ----------------------------------------------------------------------------------------------------

MINARI_VERSION = "0.5.1"  # the layout written (Minari 0.5's: data/metadata.json + data/main_data.hdf5)


def box_space(dim, low, high):
    """Minari's serialisation of a gymnasium Box (minari/serialization.py): a JSON string inside metadata.json."""
    return json.dumps({"type": "Box", "dtype": "float64", "shape": [dim], "low": [low] * dim, "high": [high] * dim})


def export_minari(demos, out, dataset_id=None):
    """A Minari dataset folder: OUT/data/main_data.hdf5 (episode_<i> groups: observations with T + 1 rows, the
    last the final observation; actions, rewards, terminations, truncations; infos/task_index) and
    OUT/data/metadata.json. Put OUT at <minari root>/<dataset id> for minari.load_dataset to find it. What Minari has
    no place for (task names, demo seeds, success, the split) goes into metadata.json under "maps" and into
    episode attributes named maps_*."""
    episodes = demos["episodes"]
    data_dir = pathlib.Path(out) / "data"
    data_dir.mkdir(parents=True, exist_ok=True)
    obs_dim = episodes[0]["obs"].shape[1]
    act_dim = episodes[0]["actions"].shape[1]
    inside = all(np.all(np.abs(e["actions"]) <= 1.0) for e in episodes)

    def write(f):
        for i, e in enumerate(episodes):
            group = f.create_group(f"episode_{i}")
            steps = len(e["actions"])
            group.create_dataset("observations", data=np.concatenate([e["obs"], e["next_obs"][-1:]]))
            group.create_dataset("actions", data=e["actions"])
            group.create_dataset("rewards", data=e["rewards"])
            group.create_dataset("terminations", data=np.arange(steps) == steps - 1 if e["end"] == "terminated"
                                 else np.zeros(steps, dtype=bool))
            group.create_dataset("truncations", data=np.arange(steps) == steps - 1 if e["end"] == "truncated"
                                 else np.zeros(steps, dtype=bool))
            group.create_dataset("infos/task_index", data=np.full(steps, e["task_index"], dtype="<i8"))
            group.attrs["id"] = i
            group.attrs["total_steps"] = steps
            group.attrs["seed"] = np.uint64(e["seed"])
            group.attrs["maps_task_index"] = np.int64(e["task_index"])
            group.attrs["maps_return"] = np.float64(e["return"])
            group.attrs["maps_success"] = np.uint8(e["success"])
            for name, fn in (("sum", np.sum), ("mean", np.mean), ("std", np.std), ("max", np.max), ("min", np.min)):
                group.attrs[f"rewards_{name}"] = float(fn(e["rewards"]))
    write_atomically(data_dir / "main_data.hdf5", write)
    metadata = {
        "dataset_id": dataset_id or f"maps/{demos['task_set'] or 'demos'}/expert-v0",
        "total_episodes": len(episodes), "total_steps": int(sum(len(e["actions"]) for e in episodes)),
        "data_format": "hdf5", "minari_version": MINARI_VERSION,
        "observation_space": box_space(obs_dim, float("-inf"), float("inf")),
        "action_space": box_space(act_dim, -1.0, 1.0) if inside else box_space(act_dim, float("-inf"), float("inf")),
        "algorithm_name": "maps collect (the committed experts' mean actions)", "author": ["maps"],
        "code_permalink": "", "description": demos["creation_command"],
        "maps": {key: demos[key] for key in ("task_set", "task_names", "env_version", "creation_command", "extra_json",
                                              "train", "valid")}}
    temporary = data_dir / f".metadata.json.tmp-{os.getpid()}"
    temporary.write_text(json.dumps(metadata, indent=1))
    os.replace(temporary, data_dir / "metadata.json")


def import_minari(folder, task_set=None):
    """A Minari dataset folder (this project's export or any other with a flat Box observation)."""
    data_dir = pathlib.Path(folder) / "data"
    try:
        metadata = read_json(data_dir / "metadata.json")
    except (OSError, ValueError) as e:
        raise FormatError(f"{data_dir / 'metadata.json'}: cannot read Minari's metadata ({e})")
    if not isinstance(metadata, dict):
        raise FormatError(f"{data_dir / 'metadata.json'}: expected a JSON object, got {type(metadata).__name__}")
    if metadata.get("data_format", "hdf5") != "hdf5":
        raise FormatError(f"{folder}: data_format '{metadata['data_format']}'; only Minari's hdf5 backend is read")
    path = data_dir / "main_data.hdf5"
    f = open_hdf5(path)
    with f:
        names = [name for name in f.keys() if name.startswith("episode_")]
        try:
            names.sort(key=lambda name: int(name[len("episode_"):]))
        except ValueError:
            raise FormatError(f"{path}: an episode group is not named episode_<number>")
        if not names:
            raise FormatError(f"{path}: no episode_<i> groups")
        episodes = []
        for name in names:
            group = f[name]
            where = f"{path}:{name}"
            if not isinstance(group.get("observations"), h5py.Dataset):
                raise FormatError(f"{where}: observations is not one array (a Dict or Tuple observation space: "
                                  f"flatten it first)")
            obs = numeric(group, where, "observations", 2)
            steps = len(obs) - 1
            if steps < 1:
                raise FormatError(f"{where}: observations has {len(obs)} rows; an episode needs T + 1 >= 2")
            actions = numeric(group, where, "actions", 2, steps)
            rewards = numeric(group, where, "rewards", 1, steps, squeeze=True)
            terminations = flag_array(group, where, "terminations", steps)
            truncations = flag_array(group, where, "truncations", steps)
            if np.any(terminations[:-1] | truncations[:-1]):
                raise FormatError(f"{where}: terminations or truncations set before the last step")
            task_index = int(group.attrs["maps_task_index"]) if "maps_task_index" in group.attrs else (
                int(group["infos/task_index"][0]) if "infos/task_index" in group else 0)
            episodes.append({"obs": obs[:-1], "next_obs": obs[1:], "actions": actions, "rewards": rewards,
                             "task_index": task_index,
                             "seed": int(group.attrs["seed"]) if "seed" in group.attrs else len(episodes),
                             "return": float(group.attrs["maps_return"]) if "maps_return" in group.attrs
                             else float(np.sum(rewards)),
                             "success": int(group.attrs.get("maps_success", 0)),
                             "end": "terminated" if terminations[-1] else "truncated"})
    if obs.shape[1] != episodes[0]["obs"].shape[1]:
        raise FormatError(f"{path}: observation widths differ across episodes")
    demos = {"episodes": episodes}
    if "maps" in metadata:
        demos.update(maps_metadata(data_dir / "metadata.json", metadata["maps"]))
    else:
        name = task_set or str(metadata.get("dataset_id", pathlib.Path(folder).name))
        tasks = max(e["task_index"] for e in episodes) + 1
        demos.update(task_set=name, task_names=[f"{name}/{k}" for k in range(tasks)],
                     env_version="unknown (imported from Minari)", creation_command="",
                     extra_json=json.dumps({"imported_from": str(folder), "format": "minari",
                                            "dataset_id": metadata.get("dataset_id")}))
        demos["train"], demos["valid"] = split_by_task(episodes)
    if task_set:
        demos["task_set"] = task_set
    check_task_indices(path, demos)
    return demos


def maps_metadata(path, maps):
    """The "maps" entry of a Minari metadata.json (this project's export), each key of its type: a hand-edited or
    damaged one is refused naming the key, not met later as a crash."""
    kinds = {"task_set": str, "task_names": list, "env_version": str, "creation_command": str, "extra_json": str,
             "train": list, "valid": list}
    if not isinstance(maps, dict):
        raise FormatError(f"{path}: \"maps\" is {type(maps).__name__}, expected an object")
    for key, kind in kinds.items():
        if not isinstance(maps.get(key), kind):
            raise FormatError(f"{path}: \"maps\".{key} is missing or not a {kind.__name__}")
    if not all(isinstance(name, str) for name in maps["task_names"]):
        raise FormatError(f"{path}: \"maps\".task_names holds a non-string")
    for key in ("train", "valid"):
        if not all(isinstance(i, int) and not isinstance(i, bool) for i in maps[key]):
            raise FormatError(f"{path}: \"maps\".{key} holds a non-integer")
    return {key: maps[key] for key in kinds}


# ----- robomimic -------------------------------------------------------------------------------------------------


def export_robomimic(demos, out):
    """This project's format 2 is robomimic's layout already (docs/datasets.md): the export is the same file."""
    write_maps(out, demos)


def import_robomimic(path, task_set=None, obs_keys=None):
    """A robomimic dataset. One of this project's (data attribute format_version) reads as it is; any other gives
    one task, its low-dim observation keys (obs_keys, default every key of data/demo_0/obs, sorted) side by side in
    that order, rewards and dones as found (zeros when absent, as robomimic's loader fills them), mask/train and
    mask/valid when present (else the last 30% for validation), seeds the demo numbers."""
    f = open_hdf5(path)
    with f:
        if "data" not in f:
            raise FormatError(f"{path}: no group 'data' (robomimic keeps its demos under data/)")
        if "format_version" in f["data"].attrs:
            f.close()
            demos = read_maps(path)
            if task_set:
                demos["task_set"] = task_set
            return demos
        names = list(f["data"].keys())
        try:
            names.sort(key=lambda name: int(name[5:]))  # robomimic's SequenceDataset orders them so
        except ValueError:
            raise FormatError(f"{path}: a member of data is not named demo_<number> (robomimic needs that)")
        if not names:
            raise FormatError(f"{path}: data holds no demos")
        keys = obs_keys or sorted(f[f"data/{names[0]}/obs"].keys())
        episodes, index = [], {}
        for name in names:
            group = f[f"data/{name}"]
            where = f"{path}:data/{name}"
            steps = int(group.attrs["num_samples"]) if "num_samples" in group.attrs else len(group["actions"])
            actions = numeric(group, where, "actions", 2, steps)

            def side_by_side(kind):
                columns = []
                for key in keys:
                    if f"{kind}/{key}" not in group:
                        raise FormatError(f"{where}: missing {kind}/{key} (observation keys: {', '.join(keys)})")
                    array = np.asarray(group[f"{kind}/{key}"][()], dtype=np.float64).reshape(steps, -1)
                    columns.append(array)
                return np.concatenate(columns, axis=1)
            obs = side_by_side("obs")
            next_obs = side_by_side("next_obs") if "next_obs" in group else np.concatenate([obs[1:], obs[-1:]])
            if not np.array_equal(next_obs[:-1], obs[1:]):
                raise FormatError(f"{where}: next_obs is not obs one step on (this project keeps one observation "
                                  f"sequence per demo)")
            if not np.all(np.isfinite(obs)) or not np.all(np.isfinite(next_obs)):
                raise FormatError(f"{where}: an observation holds a NaN or an infinite value")
            rewards = numeric(group, where, "rewards", 1, steps, squeeze=True) if "rewards" in group else np.zeros(steps)
            index[name] = len(episodes)
            episodes.append({"obs": obs, "next_obs": next_obs, "actions": actions, "rewards": rewards,
                             "task_index": 0, "seed": int(name[5:]), "return": float(np.sum(rewards)),
                             "success": 0, "end": "truncated"})
        name = task_set or pathlib.Path(path).stem
        demos = {"episodes": episodes, "task_set": name, "task_names": [f"{name}/0"],
                 "env_version": text(f["data"].attrs.get("env_args", "unknown (imported from robomimic)")),
                 "creation_command": "",
                 "extra_json": json.dumps({"imported_from": str(path), "format": "robomimic", "obs_keys": keys,
                                           "episode_end": "unknown in robomimic's layout: every demo marked "
                                                          "truncated"})}
        if "mask/train" in f and "mask/valid" in f:
            for split in ("train", "valid"):
                listed = [text(n) for n in f[f"mask/{split}"][()]]
                missing = [n for n in listed if n not in index]
                if missing:
                    raise FormatError(f"{path}: mask/{split} names {missing[0]}, which is not in data")
                demos[split] = sorted(index[n] for n in listed)
        else:
            demos["train"], demos["valid"] = split_by_task(episodes)
    return demos


# ----- helpers ---------------------------------------------------------------------------------------------------


SELF_CONTAINED = ("this tool reads a file from itself alone (no external links, external storage, virtual datasets "
                  "or user-defined links)")
# HDF5's own filters, and LZF, which h5py compiles in and registers itself (common in files h5py wrote): none is
# loaded from a plugin folder.
BUILT_IN_FILTERS = {h5py.h5z.FILTER_DEFLATE, h5py.h5z.FILTER_SHUFFLE, h5py.h5z.FILTER_FLETCHER32, h5py.h5z.FILTER_SZIP,
                    h5py.h5z.FILTER_NBIT, h5py.h5z.FILTER_SCALEOFFSET, h5py.h5z.FILTER_LZF}


def read_json(path):
    """path's JSON (experiments/process/json_input.py); FormatError naming the file when it nests too deep."""
    try:
        return json_input.read_json(path)
    except json_input.JsonTooDeep as e:
        raise FormatError(str(e)) from None


def open_hdf5(path):
    """The HDF5 file at path, open for reading, once check_self_contained has found all its data inside it."""
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise FormatError(f"{path}: cannot open as HDF5 ({e})")
    try:
        check_self_contained(f, path)
    except BaseException:
        f.close()
        raise
    return f


def check_self_contained(f, path):
    """Refuses (FormatError naming the file and the object's path) every object whose data lives outside the file:
    an external link, a user-defined link, a dataset with external raw storage or a virtual layout (issue 41). A
    file downloaded from elsewhere could otherwise make an export copy any file of this machine into a file the user
    then shares. A dataset stored through a filter that is not HDF5's own is refused too: reading it would load a
    plugin's code. Soft links must resolve inside the file, and a group may be reached by one path only, so that the
    walk ends. Attributes need no check: they are stored in their object's header."""
    def refuse(where, what):
        raise FormatError(f"{path}: '{where}' {what}")

    def describe(value):
        return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)

    def address(obj_id, where):
        try:
            return h5py.h5o.get_info(obj_id).addr
        except (KeyError, RuntimeError, OSError, ValueError) as e:
            refuse(where, f"cannot be read ({e})")

    soft_links = []
    seen_groups = {address(f.id, "/")}
    # A stack, not recursion: a file nested deeper than Python's recursion limit must be refused by name, not crash.
    stack = [(f.id, "/")]
    while stack:
        group, group_path = stack.pop()
        names = []
        try:
            group.links.iterate(names.append)
        except (KeyError, RuntimeError, OSError, ValueError) as e:
            refuse(group_path, f"cannot list its members ({e})")
        for name in names:
            where = group_path.rstrip("/") + "/" + describe(name)
            try:
                kind = group.links.get_info(name).type
            except (KeyError, RuntimeError, OSError, ValueError) as e:
                refuse(where, f"is a link that cannot be read ({e})")
            if kind == h5py.h5l.TYPE_EXTERNAL:
                file_name, target = group.links.get_val(name)
                refuse(where, f"is an external link to '{describe(file_name)}:{describe(target)}': {SELF_CONTAINED}")
            if kind == h5py.h5l.TYPE_SOFT:
                soft_links.append((group, name, where))
                continue
            if kind != h5py.h5l.TYPE_HARD:
                refuse(where, f"is a user-defined link (type {int(kind)}): {SELF_CONTAINED}")
            try:
                obj = h5py.h5o.open(group, name)
            except (KeyError, RuntimeError, OSError, ValueError) as e:
                refuse(where, f"cannot be opened ({e})")
            if isinstance(obj, h5py.h5g.GroupID):
                here = address(obj, where)
                if here in seen_groups:
                    refuse(where, "is a group linked twice (a loop or an alias); a file of this tool reaches each "
                                  "group by one path")
                seen_groups.add(here)
                stack.append((obj, where))
            elif isinstance(obj, h5py.h5d.DatasetID):
                try:
                    dcpl = obj.get_create_plist()
                    layout, externals = dcpl.get_layout(), dcpl.get_external_count()
                    files = [describe(dcpl.get_external(i)[0]) for i in range(externals)]
                    filters = [dcpl.get_filter(i) for i in range(dcpl.get_nfilters())]
                except (KeyError, RuntimeError, OSError, ValueError) as e:
                    refuse(where, f"is a dataset whose storage cannot be read ({e})")
                if layout == h5py.h5d.VIRTUAL:
                    refuse(where, f"is a virtual dataset (its data is mapped from other files): {SELF_CONTAINED}")
                if externals > 0:
                    listed = ", ".join(f"'{name}'" for name in files)
                    refuse(where, f"keeps its data in external raw files ({listed}): {SELF_CONTAINED}")
                for code, _, _, filter_name in filters:
                    if code not in BUILT_IN_FILTERS:
                        named = f" ('{describe(filter_name)}')" if describe(filter_name) else ""
                        refuse(where, f"is stored through filter {code}{named}, which HDF5 would load from a plugin:"
                                      " this tool reads a file with HDF5's built-in filters only (deflate, shuffle,"
                                      " fletcher32, szip, nbit, scaleoffset; and h5py's lzf)")
    # Resolved only once every link is known to be hard or soft, so that resolving one never leaves the file.
    for group, name, where in soft_links:
        try:
            h5py.h5o.get_info(group, name)
        except (KeyError, RuntimeError, OSError, ValueError):
            refuse(where, f"is a soft link to '{describe(group.links.get_val(name))}' that does not resolve within "
                          f"the file (dangling or a loop)")


def text(value):
    return value.decode("utf-8") if isinstance(value, (bytes, np.bytes_)) else str(value)


def numeric(f, path, key, rank, rows=None, squeeze=False):
    array = np.asarray(f[key][()])
    if squeeze and array.ndim == 2 and array.shape[1] == 1:
        array = array[:, 0]
    if array.ndim != rank or not np.issubdtype(array.dtype, np.number):
        raise FormatError(f"{path}: {key} should be a {rank}-d numeric array, got shape {array.shape} of "
                          f"{array.dtype}")
    if rows is not None and len(array) != rows:
        raise FormatError(f"{path}: {key} has {len(array)} rows, observations has {rows}")
    if not np.all(np.isfinite(array)):
        raise FormatError(f"{path}: {key} holds a NaN or an infinite value")
    return array.astype(np.float64)


def flag_array(f, path, key, rows):
    array = np.asarray(f[key][()])
    if array.ndim == 2 and array.shape[1] == 1:
        array = array[:, 0]
    if array.shape != (rows,) or not np.all((array == 0) | (array == 1)):
        raise FormatError(f"{path}: {key} should be {rows} flags (0/1 or bool), got shape {array.shape}")
    return array.astype(bool)


def split_by_task(episodes):
    """The last 30% of each task's episodes (at least one when it has two) for validation, the rest for training."""
    train, valid = [], []
    for task in sorted({e["task_index"] for e in episodes}):
        ids = [i for i, e in enumerate(episodes) if e["task_index"] == task]
        n_valid = max(1, int(0.3 * len(ids))) if len(ids) >= 2 else 0
        train += ids[:len(ids) - n_valid]
        valid += ids[len(ids) - n_valid:]
    return sorted(train), sorted(valid)


def check_task_indices(path, demos):
    for i, e in enumerate(demos["episodes"]):
        if not 0 <= e["task_index"] < len(demos["task_names"]):
            raise FormatError(f"{path}: episode {i} has task index {e['task_index']}, but there are "
                              f"{len(demos['task_names'])} task names")


def write_atomically(path, write):
    path = pathlib.Path(path)
    temporary = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        with h5py.File(temporary, "w") as f:
            write(f)
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


EXPORTERS = {"d4rl": export_d4rl, "minari": export_minari, "robomimic": export_robomimic}
IMPORTERS = {"d4rl": import_d4rl, "minari": import_minari, "robomimic": import_robomimic}


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    export = sub.add_parser("export")
    export.add_argument("--format", required=True, choices=sorted(EXPORTERS))
    export.add_argument("--dataset-id", help="Minari's dataset id (default maps/<set>/expert-v0)")
    export.add_argument("input")
    export.add_argument("output")
    imp = sub.add_parser("import")
    imp.add_argument("--format", required=True, choices=sorted(IMPORTERS))
    imp.add_argument("--task-set")
    imp.add_argument("--obs-keys", help="robomimic: the observation keys, comma-separated, in column order")
    imp.add_argument("input")
    imp.add_argument("output")
    args = parser.parse_args(argv)
    try:
        if args.command == "export":
            extra = {"dataset_id": args.dataset_id} if args.format == "minari" else {}
            EXPORTERS[args.format](read_maps(args.input), args.output, **extra)
        else:
            extra = {"obs_keys": args.obs_keys.split(",")} if args.format == "robomimic" and args.obs_keys else {}
            write_maps(args.output, IMPORTERS[args.format](args.input, task_set=args.task_set, **extra))
    except FormatError as e:
        print(f"maps data {args.command}: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
