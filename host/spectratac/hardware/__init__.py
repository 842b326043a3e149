"""Facts of the physical sensor, generated from the definitions in hardware/definitions/.

The lowest layer of the package: it imports nothing else from spectratac, so the protocol,
the device API, the digital twin and the tools can all use it. Its modules live in
`spectratac.hardware.generated` (`make regen`, tools/codegen/manifest.toml); edit the
definitions, not them:

- `generated.veml3328`: the colour sensor's register map and CONF fields (veml3328.toml),
  e.g. `veml3328.INTEGRATION_MS`, the integration times in ms by IT code.
- `generated.board`: the board's geometry as built (params.toml).
- `generated.vocabulary`: the sensor's vocabulary (vocabulary.toml): the nine contact regions
  (keypad numbering, names, mirror map, sector angles), the channel and count names
  (`s0.R` ...), the force/torque axes and their units.
"""
