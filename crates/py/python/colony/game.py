"""Capture the Flag and Death Match (the subsumption paper's game) as PettingZoo
``ParallelEnv`` s.

The agents are the robots of one team (the learner); the other team is played by
colony's scripted player, or stands idle. Underneath is the real game: the
world on the simulator, the game server with its referee and squad behaviours,
every robot's brain, exchanging their packets through colony's hub logic, so the
rules are exactly those of a live match. A robot's wheels go as the player's
``drive`` command (its reflexes still outrank it) and its shots and flag pick-ups
as the robot's own requests, which the referee checks (range, reload, reach).

With ``control="squad"`` the agents are the learner's squads instead, each
ordered with one of :data:`SQUAD_ORDERS` and carried out by the game's own squad
behaviours; a squad sees its members' observations stacked.

Observations are arrays (see ``colony_env::game::GameEnv::observe`` for every
field): ``own`` (pose, velocity, health, reload, flag carried, type), ``nearby``
(the K nearest robots, nearest first, relative to the agent), ``flags`` (both
teams' flags and bases, relative), ``patch`` (walls, water, allies and enemies
in the P x P cells around the agent). Lengths are in units of the map's longer
side.
"""

from __future__ import annotations

from typing import Any, Optional

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from . import _native
from ._actions import agent_index, choice, fields, wheels
from ._render import HumanView, check_mode
from ._seeding import EpisodeSeeds

SQUAD_ORDERS = tuple(_native.GameCore.squad_orders())
"""The squad orders, by action index: Hold, Gather, AttackNearest, CaptureFlag,
RecoverFlag, DefendBase, AttackBase."""

# Bounds of the observation's parts. Relative lengths are fractions of the map's
# longer side, so a distance reaches sqrt(2). `own`'s velocities (ahead, left) and
# turn rate are fractions of the type's top speed and turn rate, which a shoved or
# respawned robot exceeds: their bounds are the core's `motion_bounds`, from the
# map's size and the control step, loose but true.
_VELOCITIES = [4, 5]
_TURN_RATE = 6


def _own_space(length: int, motion_bounds: tuple[float, float]) -> spaces.Box:
    speed, turn = motion_bounds
    high = np.full(length, 1.0, np.float32)
    high[_VELOCITIES] = speed
    high[_TURN_RATE] = turn
    return spaces.Box(-high, high, (length,), np.float32)


class GameEnv(ParallelEnv):
    """A match of colony's strategy game, one agent per robot of the learner's team.

    Parameters:
        mode: ``"ctf"`` (Capture the Flag) or ``"dm"`` (Death Match).
        map: a battlefield file (``maps/*.map``'s format); None takes the mode's shipped map.
        learner, opponent: the teams as ``colony game`` writes them
            (``"alpha:tank,infantry bravo:scout"``); None: 6 robots each.
        opponent_policy: ``"scripted"`` (colony's bot) or ``"idle"``.
        control: ``"robot"`` (wheels, fire, pick-up per robot) or ``"squad"``
            (one order per squad).
        max_steps: control steps (0.1 s of game time each) before truncation.
        nearby: robots listed in ``nearby``; patch: cells per side of ``patch``.
        rewards: weights by name (``score``, ``outcome``, ``damage_dealt``,
            ``damage_taken``, ``destroyed``, ``flag_taken``, ``refused``).
        render_mode: ``"rgb_array"`` or ``"human"`` (the match's packets published
            to the hub at ``hub``, so colony's monitor shows it, at ``render_speed``
            times real time).

    A robot's action (robot control) is a dict: ``wheels`` (forward, turn in
    [-1, 1]), ``fire`` (0 holds, 1 fires at the nearest enemy, ``2 + k`` at the
    k-th robot of ``nearby``) and ``pickup`` (1 asks for the enemy flag).
    """

    metadata = {"name": "colony_game_v0", "render_modes": ["rgb_array", "human"], "render_fps": 10}

    def __init__(
        self,
        mode: str = "ctf",
        map: Optional[str] = None,
        *,
        learner: Optional[str] = None,
        opponent: Optional[str] = None,
        opponent_policy: str = "scripted",
        control: str = "robot",
        max_steps: int = 3000,
        nearby: int = 8,
        patch: int = 11,
        rewards: Optional[dict] = None,
        render_mode: Optional[str] = None,
        render_size: int = 400,
        hub: str = "127.0.0.1:7400",
        render_speed: float = 1.0,
        seed: int = 0,
    ):
        check_mode(self.metadata, render_mode, render_size)
        config = _native.GameConfig(
            mode=mode,
            map=map,
            learner=learner,
            opponent=opponent,
            opponent_policy=opponent_policy,
            control=control,
            max_steps=max_steps,
            nearby=nearby,
            patch=patch,
            rewards=rewards,
        )
        self.core = _native.GameCore(config, seed)
        self.mode = mode
        self.squad_control = control == "squad"
        self.render_mode = render_mode
        self.render_size = render_size
        self._human = None
        if render_mode == "human":
            self._human = HumanView(hub, self.metadata["render_fps"] * render_speed)
            self.core.set_record(True)
        self._seeds = EpisodeSeeds(seed)
        self.teams = self.core.teams
        self.robots = self.core.agents
        n = len(self.robots)
        self._parts = dict(self.core.layout)
        self._obs = {name: np.zeros((n, *shape), np.float32) for name, shape in self._parts.items()}
        self._wheels = np.zeros((n, 2), np.float64)
        self._fire = np.zeros(n, np.int64)
        self._pickup = np.zeros(n, np.bool_)
        self._score = (0, 0)
        self._winner = None
        robot_space = spaces.Dict(
            {
                "own": _own_space(self._parts["own"][0], self.core.motion_bounds),
                "nearby": spaces.Box(-1.5, 1.5, tuple(self._parts["nearby"]), np.float32),
                "flags": spaces.Box(-1.5, 1.5, tuple(self._parts["flags"]), np.float32),
                "patch": spaces.Box(0.0, 1.0, tuple(self._parts["patch"]), np.float32),
            }
        )
        if self.squad_control:
            squads = self.core.squads
            self._members = {
                f"squad_{s}": [i for i, r in enumerate(self.robots) if r[2] == s] for s in squads
            }
            size = max(len(m) for m in self._members.values())
            self._squad_size = size
            self.possible_agents = list(self._members)
            self._obs_space = spaces.Dict(
                {
                    k: spaces.Box(
                        np.broadcast_to(s.low, (size, *s.shape)),
                        np.broadcast_to(s.high, (size, *s.shape)),
                        (size, *s.shape),
                        np.float32,
                    )
                    for k, s in robot_space.spaces.items()
                }
            )
            self._act_space = spaces.Discrete(len(SQUAD_ORDERS))
        else:
            self.possible_agents = [f"robot_{r[0]}" for r in self.robots]
            self._obs_space = robot_space
            self._act_space = spaces.Dict(
                {
                    "wheels": spaces.Box(-1.0, 1.0, (2,), np.float64),
                    "fire": spaces.Discrete(2 + nearby),
                    "pickup": spaces.Discrete(2),
                }
            )
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        self.agents = []

    # The same space object for every agent and call (PettingZoo checks it is),
    # kept on the environment rather than in a cache that would outlive it.
    def observation_space(self, agent: str) -> spaces.Space:
        return self._obs_space

    def action_space(self, agent: str) -> spaces.Space:
        return self._act_space

    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None):
        self._seeds.start(seed, self.core.reset)
        self.agents = list(self.possible_agents)
        self._score, self._winner = (0, 0), None
        self._observe()
        self._publish()
        return self._observations(), {a: self._info(0, 0) for a in self.agents}

    def step(self, actions: dict[str, Any]):
        if not self.agents:
            raise RuntimeError("the episode is over: call reset()")
        live = set(self.agents)
        if self.squad_control:
            # A squad with no order this step holds.
            orders = [0] * len(self.possible_agents)
            for a, act in actions.items():
                orders[agent_index(a, self._index, live)] = choice(a, act, len(SQUAD_ORDERS), "the order")
            result = self.core.step_squads(orders)
        else:
            # A robot with no action this step stands, holds fire and picks nothing up.
            self._wheels.fill(0.0)
            self._fire.fill(0)
            self._pickup.fill(False)
            fire_codes = self._act_space["fire"].n
            for a, act in actions.items():
                i = agent_index(a, self._index, live)
                act = fields(a, act, ("wheels", "fire", "pickup"))
                self._wheels[i] = wheels(a, act["wheels"])
                self._fire[i] = choice(a, act["fire"], fire_codes, "fire")
                self._pickup[i] = choice(a, act["pickup"], 2, "pickup")
            result = self.core.step(self._wheels, self._fire, self._pickup)
        rewards, terminated, truncated, score, winner, refused, refused_orders, invalid = result
        self._score, self._winner = score, winner
        self._observe()
        alive = self.core.alive()
        obs = self._observations()
        info = self._info(refused + refused_orders, invalid)
        out_rewards, terms, truncs, infos = {}, {}, {}, {}
        for a in self.agents:
            members = self._members_of(a)
            out_rewards[a] = float(sum(rewards[i] for i in members))
            gone = not any(alive[i] for i in members)
            terms[a] = bool(terminated or gone)
            truncs[a] = bool(truncated and not terms[a])
            infos[a] = info
        self.agents = [a for a in self.agents if not (terms[a] or truncs[a])]
        self._publish()
        return obs, out_rewards, terms, truncs, infos

    def score(self) -> dict:
        """The teams' scores (captures, or kills in Death Match) and the winner, if any."""
        return {self.teams[0]: self._score[0], self.teams[1]: self._score[1], "winner": self._winner}

    def render(self):
        if self.render_mode == "rgb_array":
            return self.core.render(self.render_size, self.render_size)
        return None

    def close(self):
        if self._human is not None:
            self._human.close()
            self._human = None
            # Nothing takes the match's packets any more: stop keeping them.
            self.core.set_record(False)

    def _members_of(self, agent: str) -> list:
        return self._members[agent] if self.squad_control else [self._index[agent]]

    def _observe(self) -> None:
        o = self._obs
        self.core.observe(o["own"], o["nearby"], o["flags"], o["patch"])

    def _observations(self) -> dict:
        if not self.squad_control:
            return {a: {k: v[self._index[a]].copy() for k, v in self._obs.items()} for a in self.agents}
        out = {}
        for a in self.agents:
            members = self._members[a]
            squad = {}
            for k, v in self._obs.items():
                block = np.zeros((self._squad_size, *v.shape[1:]), np.float32)
                block[: len(members)] = v[members]
                squad[k] = block
            out[a] = squad
        return out

    def _info(self, refused: int, invalid: int) -> dict:
        return {
            "score": tuple(self._score),
            "winner": self._winner,
            "refused": refused,
            "invalid_shots": invalid,
        }

    def _publish(self) -> None:
        if self._human is not None:
            self._human.publish(self.core.take_packets())


class CaptureTheFlagEnv(GameEnv):
    """Capture the Flag on colony's shipped map: take the enemy flag to your base."""

    def __init__(self, **kwargs):
        super().__init__(mode="ctf", **kwargs)


class DeathMatchEnv(GameEnv):
    """Death Match on colony's shipped map: destroy the other team."""

    def __init__(self, **kwargs):
        super().__init__(mode="dm", **kwargs)


def parallel_env(**kwargs) -> GameEnv:
    """PettingZoo's conventional constructor name."""
    return GameEnv(**kwargs)
