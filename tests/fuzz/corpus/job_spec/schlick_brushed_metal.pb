
'schlick brushed aluminium, r 0.2, p 0.3€@R1:/
	…ëQ¸í?q=
×£pí?q=
×£pí?š™™™™™É?333333Ó?