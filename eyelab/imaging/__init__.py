"""The renderer contract: :class:`~eyelab.imaging.contract.View`,
:class:`~eyelab.imaging.contract.RenderResult`, the
:class:`~eyelab.imaging.contract.Renderer` base class, the renderers' quality options,
the memory estimate and the two-eye composition. Pure numpy."""
