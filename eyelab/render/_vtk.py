"""The one import point of VTK for eyelab (as ``pyvista/plotting/_vtk.py`` is for
PyVista): every other module of ``eyelab.render`` takes its VTK classes from here, so what
eyelab needs of VTK is listed in one place and only the modules it uses are loaded.
"""

# ruff: noqa: F401
from eyelab.core.interrupt import deferred

# a Ctrl-C landing in VTK's module initialisation crashes it: held until VTK is loaded
with deferred():
    import vtkmodules.vtkRenderingFreeType  # registers the FreeType text renderer
    import vtkmodules.vtkRenderingOpenGL2  # registers the OpenGL implementations (factories)
    from vtkmodules.util.misc import calldata_type
    from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
    from vtkmodules.vtkCommonCore import (
        VTK_FLOAT,
        VTK_OBJECT,
        vtkCommand,
        vtkFloatArray,
        vtkPoints,
        vtkUnsignedCharArray,
    )
    from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkDataObject, vtkImageData, vtkPolyData
    from vtkmodules.vtkRenderingCore import (
        vtkActor,
        vtkActor2D,
        vtkCoordinate,
        vtkPolyDataMapper2D,
        vtkPropCollection,
        vtkRenderer,
        vtkRenderWindow,
        vtkTextActor,
        vtkTextMapper,
        vtkTextProperty,
        vtkTextRenderer,
        vtkTexture,
    )
    from vtkmodules.vtkRenderingOpenGL2 import (
        vtkOpenGLPolyDataMapper,
        vtkOpenGLShaderProperty,
        vtkTextureObject,
    )

