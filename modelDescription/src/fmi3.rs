//! FMI 3.0 `modelDescription.xml`: the subset a co-simulation FMU with `Float64`
//! variables needs, mirroring the 3.0 schema's names (optional attributes are `Option`).
//!
//! The FMI 3.0 description of an FMU is derived from its FMI 2.0 one
//! ([`ModelDescription::from_fmi2`]), so both are written from one variable table: the
//! same names, value references, causalities, variabilities, descriptions, units,
//! quantities, min/max/start and dependencies. What FMI 3.0 changes:
//!
//! * `fmiVersion="3.0"`, `instantiationToken` instead of `guid`;
//! * `<Float64>` elements instead of `<ScalarVariable><Real/></ScalarVariable>`; their
//!   quantity and unit through a `declaredType` (`<TypeDefinitions><Float64Type
//!   name="Force" quantity="Force" unit="N"/>`, units in `UnitDefinitions`), as the
//!   Modelica Reference FMUs do: strict importers (rust-fmi 0.8) refuse `quantity`/`unit`
//!   on the variable itself, though the schema allows them;
//! * the independent variable `time` (unit `s`) is declared, with the value reference
//!   after the last FMI 2.0 one (the others keep theirs);
//! * `<ModelStructure>` lists `<Output>` and `<InitialUnknown>` by value reference, and
//!   `dependencies` are value references instead of 1-based indices;
//! * `canGetAndSetFMUState` / `canSerializeFMUState` are spelled with a capital S, and
//!   `canNotUseMemoryManagementFunctions` / `numberOfEventIndicators` are gone.
//!
//! ```
//! use model_description::{fmi3, ModelDescription};
//! let md2 = ModelDescription::co_simulation("m", "{1234}", "mtwin_tcp")
//!     .with_real("Fx", "input", Some(0.0), Some("N"))
//!     .with_real("dx", "output", None, Some("m"));
//! let md3 = fmi3::ModelDescription::from_fmi2(&md2);
//! assert_eq!(md3.instantiation_token, "{1234}");
//! let back = fmi3::ModelDescription::from_xml(&md3.to_xml().unwrap()).unwrap();
//! assert_eq!(back, md3);
//! assert_eq!(back.model_structure.outputs[0].value_reference, 1);
//! assert_eq!(back.model_structure.outputs[0].dependencies.as_deref(), Some("0"));
//! ```

use crate::{
    BaseUnit, DefaultExperiment, Error, LogCategories, ModelDescription as Fmi2, Unit,
    UnitDefinitions,
};
use serde::{Deserialize, Serialize};

/// `<fmiModelDescription>` of FMI 3.0.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "fmiModelDescription")]
pub struct ModelDescription {
    /// Always "3.0".
    #[serde(rename = "@fmiVersion")]
    pub fmi_version: String,
    /// Model name.
    #[serde(rename = "@modelName")]
    pub model_name: String,
    /// Checked by the FMU at instantiation (the FMI 2.0 GUID).
    #[serde(rename = "@instantiationToken")]
    pub instantiation_token: String,
    /// Description.
    #[serde(
        rename = "@description",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub description: Option<String>,
    /// Generating tool.
    #[serde(
        rename = "@generationTool",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub generation_tool: Option<String>,
    /// When the FMU was generated (ISO 8601, UTC).
    #[serde(
        rename = "@generationDateAndTime",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub generation_date_and_time: Option<String>,
    /// "flat" or "structured".
    #[serde(
        rename = "@variableNamingConvention",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub variable_naming_convention: Option<String>,
    /// `<CoSimulation>`.
    #[serde(rename = "CoSimulation")]
    pub co_simulation: CoSimulation,
    /// `<UnitDefinitions>`.
    #[serde(
        rename = "UnitDefinitions",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub unit_definitions: Option<UnitDefinitions>,
    /// `<TypeDefinitions>`.
    #[serde(
        rename = "TypeDefinitions",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub type_definitions: Option<TypeDefinitions>,
    /// `<LogCategories>`.
    #[serde(
        rename = "LogCategories",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub log_categories: Option<LogCategories>,
    /// `<DefaultExperiment>`.
    #[serde(
        rename = "DefaultExperiment",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub default_experiment: Option<DefaultExperiment>,
    /// `<ModelVariables>`.
    #[serde(rename = "ModelVariables")]
    pub model_variables: ModelVariables,
    /// `<ModelStructure>`.
    #[serde(rename = "ModelStructure")]
    pub model_structure: ModelStructure,
}

/// `<CoSimulation>` capabilities (FMI 3.0 names).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoSimulation {
    /// Name of the shared library (without extension).
    #[serde(rename = "@modelIdentifier")]
    pub model_identifier: String,
    /// Several instances per process are possible.
    #[serde(
        rename = "@canBeInstantiatedOnlyOncePerProcess",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub can_be_instantiated_only_once_per_process: Option<bool>,
    /// `fmi3GetFMUState`/`fmi3SetFMUState` supported.
    #[serde(
        rename = "@canGetAndSetFMUState",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub can_get_and_set_fmu_state: Option<bool>,
    /// FMU state serialisation supported.
    #[serde(
        rename = "@canSerializeFMUState",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub can_serialize_fmu_state: Option<bool>,
    /// The FMU has an event mode.
    #[serde(
        rename = "@hasEventMode",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub has_event_mode: Option<bool>,
    /// Variable communication step sizes are handled.
    #[serde(
        rename = "@canHandleVariableCommunicationStepSize",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub can_handle_variable_communication_step_size: Option<bool>,
}

/// `<TypeDefinitions>` (Float64 types only).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct TypeDefinitions {
    /// The types.
    #[serde(rename = "Float64Type", default)]
    pub types: Vec<Float64Type>,
}

/// `<Float64Type name= quantity= unit=>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Float64Type {
    /// Type name, referred to by a variable's `declaredType`.
    #[serde(rename = "@name")]
    pub name: String,
    /// Physical quantity.
    #[serde(rename = "@quantity", skip_serializing_if = "Option::is_none", default)]
    pub quantity: Option<String>,
    /// Unit name (defined in `UnitDefinitions`).
    #[serde(rename = "@unit", skip_serializing_if = "Option::is_none", default)]
    pub unit: Option<String>,
}

/// `<ModelVariables>` (Float64 variables only).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ModelVariables {
    /// The variables, in order.
    #[serde(rename = "Float64", default)]
    pub variables: Vec<Float64>,
}

/// `<Float64>`: a scalar real variable.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Float64 {
    /// Unique name.
    #[serde(rename = "@name")]
    pub name: String,
    /// Value reference.
    #[serde(rename = "@valueReference")]
    pub value_reference: u32,
    /// Description.
    #[serde(
        rename = "@description",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub description: Option<String>,
    /// input, output, parameter, local, independent, ...
    #[serde(
        rename = "@causality",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub causality: Option<String>,
    /// continuous, discrete, fixed, tunable, constant.
    #[serde(
        rename = "@variability",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub variability: Option<String>,
    /// exact, approx, calculated.
    #[serde(rename = "@initial", skip_serializing_if = "Option::is_none", default)]
    pub initial: Option<String>,
    /// The `<Float64Type>` giving quantity and unit.
    #[serde(
        rename = "@declaredType",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub declared_type: Option<String>,
    /// Physical quantity, e.g. `Force` (written through `declaredType` here).
    #[serde(rename = "@quantity", skip_serializing_if = "Option::is_none", default)]
    pub quantity: Option<String>,
    /// Unit name (written through `declaredType` here).
    #[serde(rename = "@unit", skip_serializing_if = "Option::is_none", default)]
    pub unit: Option<String>,
    /// Smallest value.
    #[serde(rename = "@min", skip_serializing_if = "Option::is_none", default)]
    pub min: Option<f64>,
    /// Largest value.
    #[serde(rename = "@max", skip_serializing_if = "Option::is_none", default)]
    pub max: Option<f64>,
    /// Start value.
    #[serde(rename = "@start", skip_serializing_if = "Option::is_none", default)]
    pub start: Option<f64>,
}

/// `<ModelStructure>` of FMI 3.0.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ModelStructure {
    /// `<Output>` elements.
    #[serde(rename = "Output", default)]
    pub outputs: Vec<Unknown>,
    /// `<InitialUnknown>` elements.
    #[serde(rename = "InitialUnknown", default)]
    pub initial_unknowns: Vec<Unknown>,
}

/// `<Output valueReference= dependencies=>` / `<InitialUnknown ...>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Unknown {
    /// Value reference of the unknown.
    #[serde(rename = "@valueReference")]
    pub value_reference: u32,
    /// Space-separated value references of the variables it depends on (`""`: none).
    #[serde(
        rename = "@dependencies",
        skip_serializing_if = "Option::is_none",
        default
    )]
    pub dependencies: Option<String>,
}

impl TypeDefinitions {
    /// The name of the type with `quantity` and `unit`, added when new (named after the
    /// quantity, else the unit); `None` when both are absent.
    fn declare(&mut self, quantity: &Option<String>, unit: &Option<String>) -> Option<String> {
        if let Some(t) = self
            .types
            .iter()
            .find(|t| &t.quantity == quantity && &t.unit == unit)
        {
            return Some(t.name.clone());
        }
        let base = quantity.clone().or_else(|| unit.clone())?;
        let mut name = base.clone();
        let mut k = 1;
        while self.types.iter().any(|t| t.name == name) {
            k += 1;
            name = format!("{base}{k}");
        }
        self.types.push(Float64Type {
            name: name.clone(),
            quantity: quantity.clone(),
            unit: unit.clone(),
        });
        Some(name)
    }
}

/// Name of the independent variable FMI 3.0 descriptions declare.
pub const TIME: &str = "time";

impl ModelDescription {
    /// The FMI 3.0 description of the FMU that `md` describes in FMI 2.0 (module docs):
    /// the same variables, with the independent variable [`TIME`] added after them.
    pub fn from_fmi2(md: &Fmi2) -> Self {
        let vars = &md.model_variables.variables;
        let mut types = TypeDefinitions::default();
        let mut variables: Vec<Float64> = vars
            .iter()
            .map(|v| Float64 {
                name: v.name.clone(),
                value_reference: v.value_reference,
                description: v.description.clone(),
                causality: v.causality.clone(),
                variability: v.variability.clone(),
                initial: v.initial.clone(),
                declared_type: types.declare(&v.real.quantity, &v.real.unit),
                quantity: None,
                unit: None,
                min: v.real.min,
                max: v.real.max,
                start: v.real.start,
            })
            .collect();
        let time_vr = vars
            .iter()
            .map(|v| v.value_reference + 1)
            .max()
            .unwrap_or(0);
        variables.insert(
            0,
            Float64 {
                name: TIME.into(),
                value_reference: time_vr,
                description: Some("Simulation time, in s (the independent variable)".into()),
                causality: Some("independent".into()),
                variability: Some("continuous".into()),
                initial: None,
                declared_type: types.declare(&Some("Time".into()), &Some("s".into())),
                quantity: None,
                unit: None,
                min: None,
                max: None,
                start: None,
            },
        );
        // 1-based FMI 2.0 indices -> value references
        let vr_of = |index: u32| {
            vars.get((index as usize).wrapping_sub(1))
                .map(|v| v.value_reference)
        };
        let convert = |list: &[crate::Unknown]| -> Vec<Unknown> {
            list.iter()
                .filter_map(|u| {
                    Some(Unknown {
                        value_reference: vr_of(u.index)?,
                        dependencies: u.dependencies.as_ref().map(|d| {
                            d.split_whitespace()
                                .filter_map(|i| i.parse().ok().and_then(vr_of))
                                .map(|vr| vr.to_string())
                                .collect::<Vec<_>>()
                                .join(" ")
                        }),
                    })
                })
                .collect()
        };
        let mut units = md
            .unit_definitions
            .clone()
            .unwrap_or(UnitDefinitions { units: Vec::new() });
        if !units.units.iter().any(|u| u.name == "s") {
            units.units.push(Unit {
                name: "s".into(),
                base_unit: Some(BaseUnit {
                    kg: None,
                    m: None,
                    s: Some(1),
                }),
            });
        }
        let cs = &md.co_simulation;
        ModelDescription {
            fmi_version: "3.0".into(),
            model_name: md.model_name.clone(),
            instantiation_token: md.guid.clone(),
            description: md.description.clone(),
            generation_tool: md.generation_tool.clone(),
            generation_date_and_time: md.generation_date_and_time.clone(),
            variable_naming_convention: md.variable_naming_convention.clone(),
            co_simulation: CoSimulation {
                model_identifier: cs.model_identifier.clone(),
                can_be_instantiated_only_once_per_process: cs
                    .can_be_instantiated_only_once_per_process,
                can_get_and_set_fmu_state: cs.can_get_and_set_fmu_state,
                can_serialize_fmu_state: cs.can_serialize_fmu_state,
                has_event_mode: Some(false),
                can_handle_variable_communication_step_size: cs
                    .can_handle_variable_communication_step_size,
            },
            unit_definitions: Some(units),
            type_definitions: (!types.types.is_empty()).then_some(types),
            log_categories: md.log_categories.clone(),
            default_experiment: md.default_experiment.clone(),
            model_variables: ModelVariables { variables },
            model_structure: ModelStructure {
                outputs: convert(&md.model_structure.outputs.unknowns),
                initial_unknowns: convert(&md.model_structure.initial_unknowns.unknowns),
            },
        }
    }

    /// The `<Float64Type>` a variable declares (its quantity and unit).
    pub fn declared_type(&self, v: &Float64) -> Option<&Float64Type> {
        let name = v.declared_type.as_deref()?;
        self.type_definitions
            .as_ref()?
            .types
            .iter()
            .find(|t| t.name == name)
    }

    /// The value reference of the variable named `name`.
    pub fn value_reference(&self, name: &str) -> Option<u32> {
        self.model_variables
            .variables
            .iter()
            .find(|v| v.name == name)
            .map(|v| v.value_reference)
    }

    /// The XML text (with declaration).
    pub fn to_xml(&self) -> Result<String, Error> {
        crate::xml_text(self)
    }

    /// Parses XML text.
    pub fn from_xml(xml: &str) -> Result<Self, Error> {
        quick_xml::de::from_str(xml).map_err(|e| Error(e.to_string()))
    }
}
