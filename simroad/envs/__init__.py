"""simroad.envs"""
