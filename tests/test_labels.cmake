# ctest labels of the GoogleTest cases (run at ctest time, after gtest_discover_tests has listed them
# in microshadow_tests_TESTS): `ctest -L unit` runs the in-process tests of single layers (seconds
# in all), `-L cli` the tests that run the microshadow program, `-L slow` those of a second or more
# (bakes, kernels against the oracle, sweeps, soak tests), `-L gpu` the generated shaders on a Vulkan
# device (Mesa lavapipe in CI). A test may carry several; one with none of cli, slow, gpu is unit.
# CI runs them all. A new test is unit until it is listed here: list it under cli when it runs the
# program, under slow when it takes a second or more (measured one at a time on the 2-core CI machine).
set(microshadow_gpu_tests
  "^(ShaderTest|ReprShaderTest|ReprKtx2Test|ClosedFormShader)\\."
  "^AreaShaderTest\\.(Rect)?TapsShaderMatchesTheCppTapsOnLavapipe$")
set(microshadow_cli_tests
  "^AreaCommandCli\\."
  "^AreaLightCli\\."
  "^AreaShaderTest\\.CliWritesBothLanguages$"
  "^SceneTest\\.CommandLineWritesAreaLightLayers$"
  "^BakeLimits\\.BakesThatCannotFitAreRefusedUpFrontWithTheFigures$"
  "^BakeLimits\\.MemoryStaysFlatHoweverManyBatchesAToleranceAsksFor$"
  "^BakeTest\\.BadInputAndInterruptionLeaveNoFile$"
  "^BakeTest\\.TwoDevicesAndFaultInjectionGiveTheSameData$"
  "^CliHelp\\."
  "^Distributed\\.Cli"
  "^CliTest\\."
  "^NoOpenClRuntime\\."
  "^DesignTest\\.CommandRanksAKnownBetterComparatorFirstAndRefusesBadInput$"
  "^EvalCompareTest\\."
  "^Failover\\."
  "^GoldenSet\\."
  "^HostileInput\\."
  "^IblDfgBake\\.CliWritesTheExrWithMetadataAndPreview$"
  "^IblDfgFormats\\.CliRefusesWhatAFormatCannotHold$"
  "^IblEnvFaces\\."
  "^IblFormats\\.DfgLutKtx2AndDdsReadBackEqualToTheExr$"
  "^IblFormats\\.IrradianceCubemapKtx2AndDdsReadBackEqualToTheExrCross$"
  "^IblFormats\\.PrefilteredCubemapKtx2AndDdsReadBackEqualToTheExrFaces$"
  "^IblFormats\\.UnknownExtensionsAndEncodingsAreRefused$"
  "^IblIrradianceCli\\."
  "^IblPrefilterCli\\."
  "^IblPrefilterToleranceCli\\."
  "^IblShCli\\."
  "^LutFormatsTest\\.ChoosesTheFormatByExtensionAndRefusesMismatches$"
  "^LutFormatsTest\\.DdsReadsBackThroughOpenImageIO$"
  "^LutFormatsTest\\.EveryKtx2AndDdsEncodingAnd2DLayout$"
  "^LutFormatsTest\\.ExrConvertedByOpenImageIONeverDividesByAlpha$"
  "^LutFormatsTest\\.Ktx2DdsHeaderAndPngFromBakeReadBackEqualToTheExr$"
  "^LutReaderTest\\.EveryFormatAndEncodingReadsBackEqualToTheExrWithinItsStep$"
  "^LutReaderTest\\.HostileOrMismatchedFilesAreRefusedWithTheProblemNamed$"
  "^LutReaderTest\\.EvalCompareShaderAndLutCommandsTakeEveryFormat$"
  "^LutReaderTest\\.WrongKindOfFileGetsOneLineNamingTheRightCommand$"
  "^LutReaderTest\\.RepresentationDdsOpensLikeItsExr$"
  "^PreviewTest\\."
  "^Reliability\\.ABadSidecarPathFailsBeforeComputingAndKeepsTheCsv$"
  "^Reliability\\.AnInterruptedSweepSaysWhatItKeptAndNothingElse$"
  "^Reliability\\.AnOutputNameTooLongForItsTemporariesFailsUpFront$"
  "^Reliability\\.AnUnwritableHomeStillFindsTheDevice$"
  "^Reliability\\.DamagedKernelCacheEntriesAreNamedInsteadOfAborting$"
  "^Reliability\\.DashWritesTheCsvToStandardOutputWithoutASidecar$"
  "^Reliability\\.DeviceAndOversizedInputsAreRefusedBeforeReading$"
  "^Reliability\\.FuzzSeedsAreAcceptedOrRefusedCleanly$"
  "^Reliability\\.IntegerOptionsAreDecimal$"
  "^Reliability\\.MessagesForHugeNumbersAreClear$"
  "^Reliability\\.NonRegularOutputsAreRefusedBeforeComputing$"
  "^Reliability\\.NonUtf8FileNamesWorkAndAreEscapedInTheProvenance$"
  "^Reliability\\.PlotFileNamesAreNeverParsedByAShell$"
  "^Reliability\\.PlotScriptIsFoundFromTheExecutableNotACompiledInPath$"
  "^Reliability\\.PoclVariablesThatCrashPoclAreRefused$"
  "^Reliability\\.PointSetsThatCannotFitAreRefusedWithTheFigure$"
  "^Reliability\\.QueryFileEncodingsAreReportedAtTheFirstBadByte$"
  "^Reliability\\.SpecDomainsAreCheckedBeforeTheRun$"
  "^Reliability\\.StaleTemporariesOfAKilledRunAreRemoved$"
  "^Reliability\\.SymlinkedOutputReplacesTheTargetAndKeepsTheLink$"
  "^ReprCliTest\\."
  "^ReprExportCliTest\\."
  "^ReprSweepTest\\."
  "^Resilience\\."
  "^SceneBakeTest\\.CommandLineBakesTheExampleSceneWithItsReport$"
  "^SceneTest\\.CommandLineWritesEverythingOrNothing$"
  "^SceneTest\\.RepresentationComparatorReadsEachPixelsAzimuth$"
  "^SceneTest\\.LookupsOutsideAComparatorsDomainAreCountedAndStrictRefusesThem$"
  "^DomainTest\\.EvalCountsQueriesOutsideEachComparatorsDomainAndStrictRefusesThem$"
  "^DomainTest\\.RepresentationFilesRecordTheirDomainAndEvalCountsIt$"
  "^PresetTest\\."
  "^ShaderTest\\."
  "^Signals\\."
  "^StratifiedBakeCli\\."
  "^SweepCli\\."
  "^SweepIntegrity\\.ASweepBegunOnOneDeviceResumesOnAllOfThem$"
  "^IblReliability\\.(Sigterm|ARerunWithFewerMips|TwoOutputs|AnOutFolder|NumericOptions|.*Failover)"
  "^SceneReliability\\.(Sigterm|FailingDeviceOfTwo|OutputProblems|FittedSceneLut|LutsNamedAAndAError)"
  "^ExactJobsTest\\.(SweepCommand|ReprBakeCommand|BakeCommand)")
set(microshadow_slow_tests
  "^ReprPresetMax\\."
  "^ReprAnisotropicCorrectedTest\\.ThePresetMeetsItsMeasuredAccuracyAgainstTheExactTerm$"
  "^Distributed\\.CliSceneShardsMergeToOneProcess$"
  "^ExactTerm\\.AgreesWithTheScalarOracleOnAnisotropicAndUniformQueries$"
  "^ExactKernel\\.(FloatKernelReachesItsMeasuredAccuracy|DoubleKernelAgreesWithTheEvaluatorOnAzimuthMeans)$"
  "^ExactJobsTest\\.VerifyAgainstTheExactMethodPassesARightBakeAndFailsAShiftedOne$"
  "^ClosedFormFit\\.RecoversTheCoefficientsThatGeneratedTheData$"
  "^IblReliability\\.(Sigterm|ARerunWithFewerMips)"
  "^SceneReliability\\.(Sigterm|FailingDeviceOfTwo)"
  "^AreaLightExactInner\\.AgreesWithTheSampledPathWithinBars$"
  "^AreaLightKernel\\.(AgreesWithTheOracleWithinStatisticalBars|WholeHemisphereLambertIsTheCosineWeightedMean)$"
  "^AreaLightLobe\\.HemisphereGgxLobeIntegralIsTheDirectionalAlbedo$"
  "^SceneTest\\.AreaLightsMatchTheAreaIntegrandPerPixel$"
  "^ClosedFormSearch\\."
  "^PresetTest\\."
  "^LutReaderTest\\.CutOrBitFlippedFilesOfEveryFormatAreRefusedOrReadAsValidLuts$"
  "^LutReaderTest\\.EvalCompareShaderAndLutCommandsTakeEveryFormat$"
  "^LutReaderTest\\.WrongKindOfFileGetsOneLineNamingTheRightCommand$"
  "^BakeLimits\\.MemoryStaysFlatHoweverManyBatchesAToleranceAsksFor$"
  "^BakeTest\\.BadInputAndInterruptionLeaveNoFile$"
  "^BakeTest\\.TwoDevicesAndFaultInjectionGiveTheSameData$"
  "^BenchSmoke\\.EveryBenchmarkRunsAtATinySize$"
  "^ClosedFormShader\\."
  "^DesignTest\\.CommandRanksAKnownBetterComparatorFirstAndRefusesBadInput$"
  "^Failover\\.EvalWithAFailingDeviceGivesTheSameBytes$"
  "^GoldenSet\\."
  "^HostileInput\\.OddButValidQueryFilesWork$"
  "^IblDfgExact\\.AgreesWithTheIndependentQuadratureTo1e10$"
  "^IblDfgExact\\.VerifyCatchesACorruptedTexel$"
  "^IblDfgFormats\\.FourChannelsRgba16fAndSqrtParameterization$"
  "^IblDfgKernel\\."
  "^IblDfgQuadrature\\.ConvergedAndBoundedOverALut$"
  "^IblFormats\\.IrradianceCubemapKtx2AndDdsReadBackEqualToTheExrCross$"
  "^IblFormats\\.PrefilteredCubemapKtx2AndDdsReadBackEqualToTheExrFaces$"
  "^IblIrradianceKernel\\.WithinItsBoundOfTheOracle$"
  "^IblPrefilter\\.LinearEnvironmentAcrossSeams$"
  "^IblPrefilterKernel\\."
  "^IblPrefilterTolerance\\.KernelPathMeetsTheToleranceToo$"
  "^KernelsOnTheSamePoints\\."
  "^LutFormatsTest\\.DdsReadsBackThroughOpenImageIO$"
  "^LutFormatsTest\\.EveryKtx2AndDdsEncodingAnd2DLayout$"
  "^LutFormatsTest\\.ExrConvertedByOpenImageIONeverDividesByAlpha$"
  "^LutFormatsTest\\.Ktx2DdsHeaderAndPngFromBakeReadBackEqualToTheExr$"
  "^OpenClKernel\\.DoublePrecisionBuildFollowsTheOracleOnTheSamePoints$"
  "^OpenClKernel\\.MatchesOracleOnAnisotropicQueries$"
  "^OpenClKernel\\.MatchesOracleOnIsotropicQueries$"
  "^OpenClKernel\\.MatchesWeightedOracleOnTheSamePoints$"
  "^OracleVndf\\.SamplerMatchesPdfChiSquare$"
  "^RareEvents\\."
  "^Reliability\\.DamagedKernelCacheEntriesAreNamedInsteadOfAborting$"
  "^Reliability\\.FuzzSeedsAreAcceptedOrRefusedCleanly$"
  "^Reliability\\.MessagesForHugeNumbersAreClear$"
  "^Reliability\\.PlotFileNamesAreNeverParsedByAShell$"
  "^Reliability\\.PlotScriptIsFoundFromTheExecutableNotACompiledInPath$"
  "^ReprShaderTest\\."
  "^ReprSweepTest\\."
  "^Resilience\\.EvalKilledAtRandomMomentsLeavesThePreviousFileIntact$"
  "^Resilience\\.SweepIsTheSameAcrossChunkSizesAndDeviceCounts$"
  "^Resilience\\.SweepKilledAtRandomMomentsResumesToTheSameBytes$"
  "^SceneBakeTest\\.CommandLineBakesTheExampleSceneWithItsReport$"
  "^SceneTest\\.CommandLineWritesEverythingOrNothing$"
  "^SceneTilesTest\\."
  "^ShaderTest\\."
  "^Signals\\."
  "^StratifiedBake\\.DoubleKernelsAgreeWithFloat$"
  "^StratifiedBakeCli\\."
  "^StratifiedBenchSmoke\\."
  "^Stress\\.BothFormsAgreeOnTheSamePointsAtTheExtremes$"
  "^Stress\\.FloatKernelFollowsDoubleOracleAtTheExtremes$"
  "^SweepIntegrity\\.ASweepBegunOnOneDeviceResumesOnAllOfThem$"
  "^SweepIntegrity\\.EveryKindOfChunkDamageIsSetAsideAndRecomputed$"
  "^SweepRun\\.ResumeAfterInterruptionSkipsFinishedChunksAndMatchesACleanRun$"
  "^SweepRun\\.ShardsMergeToTheUnsplitFile$")

function(microshadow_matches test patterns result)
  set(${result} FALSE PARENT_SCOPE)
  foreach(pattern IN LISTS ${patterns})
    if(test MATCHES "${pattern}")
      set(${result} TRUE PARENT_SCOPE)
      return()
    endif()
  endforeach()
endfunction()

foreach(test IN LISTS microshadow_tests_TESTS)
  set(labels "")
  foreach(label gpu cli slow)
    microshadow_matches("${test}" microshadow_${label}_tests matched)
    if(matched)
      list(APPEND labels ${label})
    endif()
  endforeach()
  if(NOT labels)
    set(labels unit)
  endif()
  set_tests_properties("${test}" PROPERTIES LABELS "${labels}")
endforeach()
