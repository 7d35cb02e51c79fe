"""Reference implementations to check the engine against (MDP 3.6 bridge, :mod:`.mdp`)."""
