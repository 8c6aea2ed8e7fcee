"""``modelDescription.xml`` of an FMI 2.0 FMU for model exchange and co-simulation."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from ..._version import __version__

__all__ = ["model_description"]

#: the FMU's capabilities (both interfaces): no FMU state, no directional derivatives
_COMMON = {"needsExecutionTool": "false", "canBeInstantiatedOnlyOncePerProcess": "false",
           "canNotUseMemoryManagementFunctions": "false", "canGetAndSetFMUstate": "false",
           "canSerializeFMUstate": "false", "providesDirectionalDerivative": "false"}


def _number(value):
    return repr(float(value))


def model_description(layout, identifier, guid, name, description, source_files,
                      stop_time=None, tolerance=None):
    """The text of ``modelDescription.xml``.

    Parameters
    ----------
    layout : FmuVariables
    identifier : str
        The ``modelIdentifier`` (a C identifier; the binary's file name).
    guid : str
    name, description : str
        ``modelName`` and its description.
    source_files : sequence of str
        The files in ``sources/`` an importer compiles.
    stop_time, tolerance : float, optional
        The ``DefaultExperiment``'s stop time [s] and relative tolerance.

    Returns
    -------
    str
    """
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": name, "guid": guid, "description": description,
        "generationTool": f"kanedyn {__version__}", "variableNamingConvention": "flat",
        "numberOfEventIndicators": "0"})
    for tag, extra in (("ModelExchange", {"completedIntegratorStepNotNeeded": "false"}),
                       ("CoSimulation", {"canHandleVariableCommunicationStepSize": "true",
                                         "canInterpolateInputs": "true",
                                         "maxOutputDerivativeOrder": "0",
                                         "canRunAsynchronuously": "false"})):
        element = ET.SubElement(root, tag, {"modelIdentifier": identifier, **_COMMON,
                                            **extra})
        files = ET.SubElement(element, "SourceFiles")
        for file in source_files:
            ET.SubElement(files, "File", {"name": file})
    units = sorted({v.unit for v in layout.variables if v.unit})
    if units:
        definitions = ET.SubElement(root, "UnitDefinitions")
        for unit in units:
            ET.SubElement(definitions, "Unit", {"name": unit})
    categories = ET.SubElement(root, "LogCategories")
    ET.SubElement(categories, "Category", {"name": "logEvents",
                                           "description": "projections onto the constraints"})
    ET.SubElement(categories, "Category", {"name": "logStatusError",
                                           "description": "errors"})
    experiment = {"startTime": "0.0"}
    if stop_time is not None:
        experiment["stopTime"] = _number(stop_time)
    if tolerance is not None:
        experiment["tolerance"] = _number(tolerance)
    ET.SubElement(root, "DefaultExperiment", experiment)
    variables = ET.SubElement(root, "ModelVariables")
    for v in layout.variables:
        attributes = {"name": v.name, "valueReference": str(v.value_reference),
                      "description": v.description, "causality": v.causality,
                      "variability": v.variability}
        if v.initial is not None:
            attributes["initial"] = v.initial
        scalar = ET.SubElement(variables, "ScalarVariable", attributes)
        real = {}
        if v.start is not None:
            real["start"] = _number(v.start)
        if v.unit:
            real["unit"] = v.unit
        if v.derivative is not None:
            real["derivative"] = str(v.derivative)
        ET.SubElement(scalar, "Real", real)
    structure = ET.SubElement(root, "ModelStructure")
    derivatives = layout.derivatives
    calculated = [k + 1 for k, v in enumerate(layout.variables)
                  if v.causality == "output" and v.initial == "calculated"]
    for tag, indices in (("Outputs", layout.block("output")), ("Derivatives", derivatives),
                         ("InitialUnknowns", sorted(derivatives + calculated))):
        element = ET.SubElement(structure, tag)
        for index in indices:
            ET.SubElement(element, "Unknown", {"index": str(index)})
    ET.indent(root)
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            + ET.tostring(root, encoding="unicode") + "\n")
