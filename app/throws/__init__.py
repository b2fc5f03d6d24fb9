"""Throws in a world: playing a validated throw and measuring where the ball landed
(`execution`), training the library through the rig (`training`), the library file (`library_file`)."""
