"""Record the scripted policy's episodes as demonstrations (``docs/design.md``, Learning).

    python -m agents.demos --env tactile_gym/HingeProbePrimitive-v2 --episodes 80 --out demos
    python -m agents.demos --env tactile_gym/HingeProbePrimitive-v2 --minari \
        tactile_gym/HingeProbePrimitive-v2/scripted-v0

runs the scripted policy (on the 6-D ids, the scripted skill executor) on episodes seeded
``DEMO_SEED + k`` (``agents.seeds``) and writes ``<out>/<Name>.npz``, whose format
``agents.demonstrations`` documents; with ``--minari DATASET_ID`` it also writes them as a
Minari dataset, which ``minari.load_dataset(DATASET_ID)`` reads (the ``[clients]`` extra
installs Minari).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from .cli import KEY_VALUE_HELP, KNOWN_ENV_IDS, KeyValue, make_parser, run_main
from .demonstrations import demos_path, record_demos, save_demos, save_minari
from .seeds import DEMO_SEED

__all__: list[str] = []


def main(argv: list[str] | None = None) -> Path:
    parser = make_parser(__spec__.name if __spec__ else "agents.demos", __doc__)
    parser.add_argument("--env", required=True, help=f"one of {', '.join(KNOWN_ENV_IDS)}")
    parser.add_argument("--episodes", type=int, default=80, help="episodes to record")
    parser.add_argument(
        "--seed", type=int, default=DEMO_SEED, help="seed of the first episode (then +1 each)"
    )
    parser.add_argument("--out", default="demos", help="folder of <Name>.npz")
    parser.add_argument(
        "--minari",
        default=None,
        metavar="DATASET_ID",
        help="also write a Minari dataset of this id (e.g. tactile_gym/<Name>/scripted-v0)",
    )
    parser.add_argument(
        "--env-kwargs",
        nargs="+",
        action=KeyValue,
        default={},
        metavar="KEY:VALUE",
        help=f"gym.make keywords, e.g. observation_mode:flat; {KEY_VALUE_HELP}",
    )
    args = parser.parse_args(argv)
    start = time.monotonic()
    demos = record_demos(args.env, args.episodes, args.seed, args.env_kwargs)
    path = save_demos(demos, demos_path(args.out, args.env))
    if args.minari is not None:
        dataset = save_minari(demos, args.minari)
        print(f"Minari dataset {args.minari}: {dataset.total_episodes} episodes")
    print(
        f"{args.episodes} episodes (seeds {args.seed}..{args.seed + args.episodes - 1}), "
        f"{len(demos)} steps, mean final error {1e3 * demos.final_position_error.mean():.2f} mm, "
        f"success {100 * demos.success.mean():.0f} %, {time.monotonic() - start:.0f} s: {path}"
    )
    return path


if __name__ == "__main__":
    sys.exit(run_main(main))
