"""Reinforcement learning glue: rl_games PPO (`train`) and policy playback with video (`play`)."""
