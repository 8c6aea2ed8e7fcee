"""``modelDescription.xml`` of an FMU for model exchange and co-simulation (FMI 2.0 or
3.0), and FMI 3.0's ``sources/buildDescription.xml``.

The two versions differ in form, not in content: FMI 2.0 lists ``ScalarVariable``
elements with a ``Real`` child, refers to them by 1-based index and names its
sources in the interfaces; FMI 3.0 lists ``Float64`` elements, declares the
independent variable ``time``, refers to variables by value reference and names its
sources in ``buildDescription.xml``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from ..._version import __version__

__all__ = ["model_description", "build_description"]

#: the interfaces' capabilities: no FMU state, no directional derivatives
_COMMON = {
    2: {"needsExecutionTool": "false", "canBeInstantiatedOnlyOncePerProcess": "false",
        "canNotUseMemoryManagementFunctions": "false", "canGetAndSetFMUstate": "false",
        "canSerializeFMUstate": "false", "providesDirectionalDerivative": "false"},
    3: {"needsExecutionTool": "false", "canBeInstantiatedOnlyOncePerProcess": "false",
        "canGetAndSetFMUState": "false", "canSerializeFMUState": "false",
        "providesDirectionalDerivatives": "false", "providesAdjointDerivatives": "false"}}
#: per version: (model exchange's, co-simulation's) own attributes; the projection
#: events need fmi*CompletedIntegratorStep
_INTERFACES = {
    2: ({"completedIntegratorStepNotNeeded": "false"},
        {"canHandleVariableCommunicationStepSize": "true", "canInterpolateInputs": "true",
         "maxOutputDerivativeOrder": "0", "canRunAsynchronuously": "false"}),
    3: ({"needsCompletedIntegratorStep": "true"},
        {"canHandleVariableCommunicationStepSize": "true", "maxOutputDerivativeOrder": "0",
         "hasEventMode": "false", "providesIntermediateUpdate": "false",
         "mightReturnEarlyFromDoStep": "false"})}


def _number(value):
    return repr(float(value))


def _text(root):
    ET.indent(root)
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            + ET.tostring(root, encoding="unicode") + "\n")


def _interfaces(root, version, identifier, source_files):
    for tag, extra in zip(("ModelExchange", "CoSimulation"), _INTERFACES[version]):
        element = ET.SubElement(root, tag, {"modelIdentifier": identifier,
                                            **_COMMON[version], **extra})
        if version == 2:
            files = ET.SubElement(element, "SourceFiles")
            for file in source_files:
                ET.SubElement(files, "File", {"name": file})


def _units_categories_experiment(root, layout, stop_time, tolerance, extra_units=()):
    units = sorted({v.unit for v in layout.variables if v.unit} | set(extra_units))
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


def _attributes(v):
    attributes = {"name": v.name, "valueReference": str(v.value_reference),
                  "description": v.description, "causality": v.causality,
                  "variability": v.variability}
    if v.initial is not None:
        attributes["initial"] = v.initial
    return attributes


def _values(v, derivative):
    values = {}
    if v.start is not None:
        values["start"] = _number(v.start)
    if v.unit:
        values["unit"] = v.unit
    if v.nominal is not None:
        values["nominal"] = _number(v.nominal)
    if v.derivative is not None:
        values["derivative"] = str(derivative)
    return values


def _structure(root, layout, version):
    """``ModelStructure``: outputs, state derivatives and initial unknowns, by 1-based
    index (FMI 2.0) or value reference (FMI 3.0)."""
    derivatives = layout.derivatives
    calculated = [k + 1 for k, v in enumerate(layout.variables)
                  if v.causality == "output" and v.initial == "calculated"]
    lists = (layout.block("output"), derivatives, sorted(derivatives + calculated))
    structure = ET.SubElement(root, "ModelStructure")
    if version == 2:
        for tag, indices in zip(("Outputs", "Derivatives", "InitialUnknowns"), lists):
            element = ET.SubElement(structure, tag)
            for index in indices:
                ET.SubElement(element, "Unknown", {"index": str(index)})
        return
    for tag, indices in zip(("Output", "ContinuousStateDerivative", "InitialUnknown"), lists):
        for index in indices:
            reference = layout.variables[index - 1].value_reference
            ET.SubElement(structure, tag, {"valueReference": str(reference)})
    for v in layout.variables[len(layout.variables) - layout.n_indicators:]:
        ET.SubElement(structure, "EventIndicator", {"valueReference": str(v.value_reference)})


def model_description(layout, identifier, guid, name, description, source_files,
                      stop_time=None, tolerance=None, fmi_version=2, event_indicators=0):
    """The text of ``modelDescription.xml``.

    Parameters
    ----------
    layout : FmuVariables
    identifier : str
        The ``modelIdentifier`` (a C identifier; the binary's file name).
    guid : str
        FMI 2.0's ``guid``, FMI 3.0's ``instantiationToken``.
    name, description : str
        ``modelName`` and its description.
    source_files : sequence of str
        The files in ``sources/`` an importer compiles (FMI 2.0 lists them here;
        FMI 3.0 in :func:`build_description`).
    stop_time, tolerance : float, optional
        The ``DefaultExperiment``'s stop time [s] and relative tolerance.
    fmi_version : {2, 3}
    event_indicators : int
        FMI 2.0's ``numberOfEventIndicators`` (two per contact of a model with
        contacts; FMI 3.0 declares them as variables, ``layout.n_indicators``).

    Returns
    -------
    str
    """
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": f"{fmi_version}.0", "modelName": name,
        ("guid" if fmi_version == 2 else "instantiationToken"): guid,
        "description": description, "generationTool": f"kanedyn {__version__}",
        "variableNamingConvention": "flat"})
    if fmi_version == 2:
        root.set("numberOfEventIndicators", str(event_indicators))
    _interfaces(root, fmi_version, identifier, source_files)
    _units_categories_experiment(root, layout, stop_time, tolerance,
                                 extra_units=("s",) if fmi_version == 3 else ())
    variables = ET.SubElement(root, "ModelVariables")
    if fmi_version == 3:  # the independent variable, after the others' references
        ET.SubElement(variables, "Float64", {
            "name": "time", "valueReference": str(len(layout.variables)),
            "causality": "independent", "variability": "continuous",
            "description": "simulation time [s]", "unit": "s"})
    for v in layout.variables:
        if fmi_version == 2:
            scalar = ET.SubElement(variables, "ScalarVariable", _attributes(v))
            ET.SubElement(scalar, "Real", _values(v, v.derivative))
        else:
            state = None if v.derivative is None \
                else layout.variables[v.derivative - 1].value_reference
            ET.SubElement(variables, "Float64", {**_attributes(v), **_values(v, state)})
    _structure(root, layout, fmi_version)
    return _text(root)


def build_description(identifier, source_files):
    """The text of FMI 3.0's ``sources/buildDescription.xml``: the C99 sources of the
    binary and the math library it links.

    Parameters
    ----------
    identifier : str
    source_files : sequence of str

    Returns
    -------
    str
    """
    root = ET.Element("fmiBuildDescription", {"fmiVersion": "3.0"})
    configuration = ET.SubElement(root, "BuildConfiguration",
                                  {"modelIdentifier": identifier})
    files = ET.SubElement(configuration, "SourceFileSet", {"language": "C99"})
    for file in source_files:
        ET.SubElement(files, "SourceFile", {"name": file})
    ET.SubElement(configuration, "Library", {"name": "m"})
    return _text(root)
